"""Light field readers and writers. Every reader returns an array (T, S, V, U[, C]) plus
metadata; :func:`read_light_field` picks the reader from the path. Formats, options and
the alpha / weight convention: docs/INPUTS.md. Axis order and slope sign:
docs/CONVENTIONS.md. :func:`check_intensity` warns about values off the scale the
detector reads them on; :func:`scale_bit_depth` rescales them.
"""

from .._warnings import IntensityWarning, LensletSizeWarning
from ._shared import LightFieldFile, centre_views
from .eslf import detect_lenslet_size, read_eslf, write_eslf
from .formats import OPTIONS, InputFormat, ReaderOption
from .hci import HciScene, read_hci
from .hdf5 import read_hdf5
from .intensity import check_intensity, intensity_range, scale_bit_depth
from .mat import read_mat
from .mosaic import read_mosaic, write_mosaic
from .numpy_files import read_numpy
from .pfm import read_pfm, write_pfm
from .read import FORMATS, guess_format, read_light_field
from .views import read_views, write_views

__all__ = [
    "FORMATS",
    "HciScene",
    "InputFormat",
    "IntensityWarning",
    "LensletSizeWarning",
    "LightFieldFile",
    "OPTIONS",
    "ReaderOption",
    "centre_views",
    "check_intensity",
    "detect_lenslet_size",
    "guess_format",
    "intensity_range",
    "read_eslf",
    "read_hci",
    "read_hdf5",
    "read_light_field",
    "read_mat",
    "read_mosaic",
    "read_numpy",
    "read_pfm",
    "read_views",
    "scale_bit_depth",
    "write_eslf",
    "write_mosaic",
    "write_pfm",
    "write_views",
]
