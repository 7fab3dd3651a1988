"""liff: light field features in scale and depth, as an OpenCV Feature2D.

Swap ``cv2.SIFT.create()`` for ``liff.LiFF.create()`` and pass a light field of
shape ``(T, S, V, U)`` or ``(T, S, V, U, C)`` (view row, view column, pixel row,
pixel column, channel) instead of an image. Keypoints and descriptors are what
``cv2.SIFT`` returns; each keypoint's slope (pixels per view step, equal to HCI
disparity) is in ``class_id`` and read with :func:`keypoint_slopes`.
"""

from ._core import (
    getNumThreads,
    getWorkingMemoryReuse,
    keptWorkingMemoryBytes,
    opencvVersion,
    releaseWorkingMemory,
    setNumThreads,
    setWorkingMemoryReuse,
)
from ._detector import PARAMETERS, LiFF, LiFF_create
from ._version import __version__  # noqa: F401 (liff.__version__)
from ._warnings import IntensityWarning, LensletSizeWarning, LiffWarning, MissingViewsWarning, SlopeRangeWarning
from .camera import LightFieldCamera
from .keypoint_rows import SLOPE_SCALE, keypoint_slopes
from .pose import PoseEstimationError, estimate_relative_pose

__all__ = [
    "IntensityWarning",
    "LensletSizeWarning",
    "LiFF",
    "LiFF_create",
    "LiffWarning",
    "MissingViewsWarning",
    "PARAMETERS",
    "SLOPE_SCALE",
    "SlopeRangeWarning",
    "keypoint_slopes",
    "LightFieldCamera",
    "estimate_relative_pose",
    "PoseEstimationError",
    "setNumThreads",
    "getNumThreads",
    "opencvVersion",
    "releaseWorkingMemory",
    "keptWorkingMemoryBytes",
    "setWorkingMemoryReuse",
    "getWorkingMemoryReuse",
]

# Submodules load on first use (``import liff; liff.io.read_light_field(...)`` works
# without paying for readers, plotting or pycolmap at ``import liff``).
_SUBMODULES = frozenset({"batch", "captures", "colmap", "demo", "feature_file", "hloc", "io",
                         "keypoint_rows", "matching", "outputs", "plot", "preprocess",
                         "synthetic"})


def __getattr__(name):
    if name in _SUBMODULES:
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'liff' has no attribute {name!r}")
