"""The input formats liff reads, declared once.

:data:`FORMATS` lists every light field format: its name, what it is, the names it is
recognised by, how a file or folder so named is checked to hold a light field (its
content), its reader and the reader options it takes. :data:`OPTIONS` lists the reader
options: the reader's keyword and the command line's flag. Everything else is derived
from these two: :func:`liff.io.read_light_field`'s choice of reader and option check,
the ``liff`` command's ``--format`` choices and reader flags with their help, the list
of formats in docs/INPUTS.md (:func:`formats_table`, checked by a test), the fuzz
targets (fuzz/readers.py) and the folder walk (:mod:`liff.io.layout`).

Adding a reader is one module (its ``read_*`` function returning a
:class:`~liff.io.LightFieldFile`) plus one :class:`InputFormat` entry here;
tests/io/test_format_registry.py fails for a reader module that has none.
"""

from __future__ import annotations

import argparse
import fnmatch
import os
from dataclasses import dataclass, field
from typing import Callable, Dict, Optional, Sequence, Tuple, Union

from .eslf import read_eslf
from .hci import is_hci_scene, read_hci_light_field
from .hdf5 import dataset_shapes, read_hdf5
from .images import IMAGE_SUFFIXES
from .mat import holds_light_field as mat_holds_light_field
from .mat import read_mat
from .mosaic import read_mosaic
from .numpy_files import read_numpy, stored_shapes
from .views import read_views, view_names


@dataclass(frozen=True)
class ReaderOption:
    """A reader option: the readers' keyword and the command line's flag.

    Attributes
    ----------
    keyword : str
        The keyword the readers (and :func:`liff.io.read_light_field`) take.
    flag : str
        The ``liff`` flag that sets it.
    help : str
        What it sets, for the flag's help and docs/INPUTS.md.
    metavar : str or tuple of str
        The value's name(s) in the help.
    type : callable
        Converts the flag's text.
    nargs : int, optional
        The values the flag takes (the keyword then gets a tuple).
    """

    keyword: str
    flag: str
    help: str
    metavar: Union[str, Tuple[str, ...]]
    type: Callable = str
    nargs: Optional[int] = None

    def value(self, given):
        """The keyword's value from the parsed flag's ``given`` (a tuple for nargs)."""
        return tuple(given) if self.nargs else given

    def shown(self, value) -> str:
        """The flag with ``value`` as typed on the command line: ``--grid 3 3``."""
        values = value if isinstance(value, (tuple, list)) else (value,)
        return " ".join([self.flag] + [str(v) for v in values])


def _whole_number(text: str, low: int, high: Optional[int], expected: str) -> int:
    """``text`` as a whole number in [low, high] (no upper bound for None), else an
    argparse.ArgumentTypeError naming the value and ``expected``."""
    try:
        n: Optional[int] = int(text)
    except ValueError:
        n = None
    if n is None or n < low or (high is not None and n > high):
        raise argparse.ArgumentTypeError(f"{text}; expected {expected}")
    return n


def lenslet_size(text: str) -> int:
    """``--lenslet``'s type: a whole number >= 2 (a lenslet of one pixel holds one view)."""
    return _whole_number(text, 2, None, "a lenslet size N >= 2 pixels (each lenslet holds N x "
                         "N views; 1 is an ordinary image), e.g. 14 for the Stanford Lytro archive")


def views_kept(text: str) -> int:
    """``--keep-views``' type: a whole number >= 1 of centre views kept on each axis."""
    return _whole_number(text, 1, None, "a whole number K >= 1 of centre views to keep on each "
                         "axis, e.g. 11 of a Lytro's 14")


def bits(text: str) -> int:
    """``--bit-depth``'s type: a whole number of bits from 1 to 16, as
    :func:`liff.io.scale_bit_depth` takes."""
    return _whole_number(text, 1, 16, "a whole number of bits B from 1 to 16 (at most 8 for "
                         "8-bit images), e.g. 12 for 12-bit sensor data in 16-bit files")


#: every reader option, by keyword; ``bit_depth`` applies to every format
OPTIONS: Dict[str, ReaderOption] = {o.keyword: o for o in (
    ReaderOption("grid", "--grid", "view grid (T, S): required for a mosaic; for views, the "
                 "grid the names must fit (catches a missing last row or column)",
                 ("T", "S"), int, 2),
    ReaderOption("n", "--lenslet", "lenslet size of an ESLF image (default: detected from the "
                 "image; 14 in the Stanford Lytro archive, 15 from the Light Field Toolbox)",
                 "N", lenslet_size),
    ReaderOption("keep", "--keep-views", "ESLF: keep the centre K x K views (e.g. 11 of a "
                 "Lytro's 14)", "K", views_kept),
    ReaderOption("pattern", "--pattern", "views: regex with named groups t and s (or index) "
                 "for the file names", "REGEX"),
    ReaderOption("key", "--key", "the array, variable or dataset holding the light field",
                 "NAME"),
    ReaderOption("bit_depth", "--bit-depth", "the values are B-bit (e.g. 10 or 12 for sensor "
                 "data in 16-bit files, 8 for floats in 0..255): rescale them to the dtype's "
                 "range", "B", bits),
)}
#: options every format takes (applied after reading)
COMMON_OPTIONS = ("bit_depth",)


@dataclass(frozen=True)
class InputFormat:
    """One light field format.

    Attributes
    ----------
    name : str
        ``format=`` / ``--format``.
    what : str
        What it is, in a few words.
    names : tuple of str
        The names it is recognised by (``fnmatch`` patterns, lower case, ``IMAGE``
        standing for any image ending); for a folder format, the files it holds. Empty:
        never recognised, only read when named (``format=``).
    read : callable
        The reader: ``read(path, **options)`` returns a LightFieldFile.
    options : tuple of str
        The keywords of :data:`OPTIONS` it takes (besides :data:`COMMON_OPTIONS`).
    folder : bool
        A folder (True) or a file.
    folder_test : callable, optional
        For a folder format: ``(names) -> bool``, whether a folder holding the files
        ``names`` is one (by their names).
    holds_light_field : callable, optional
        ``(path) -> bool or None``: whether a path so named holds a light field, from
        its content (headers only): False for files liff writes beside its outputs
        (a slope map, a feature file), None when the content cannot tell.
    fuzz : tuple, optional
        (name ending of the fuzz input, or None for a folder; options to read it with):
        fuzz/readers.py fuzzes the reader so.
    """

    name: str
    what: str
    names: Tuple[str, ...]
    read: Callable
    options: Tuple[str, ...] = ()
    folder: bool = False
    folder_test: Optional[Callable[[Sequence[str]], bool]] = None
    holds_light_field: Optional[Callable[[str], Optional[bool]]] = None
    fuzz: Optional[Tuple[Optional[str], dict]] = field(default=None)

    def recognises(self, path: str, names: Sequence[str] = ()) -> bool:
        """Whether ``path`` has this format's names (for a folder: ``names``, its files)."""
        if self.folder and self.folder_test is not None:
            return self.folder_test(names)
        return _fits(os.path.basename(path), self.names)

    def takes(self) -> Tuple[str, ...]:
        """Every keyword it takes: its own options, then the common ones."""
        return self.options + COMMON_OPTIONS


def _fits(name: str, patterns: Sequence[str]) -> bool:
    name = name.lower()
    return any(fnmatch.fnmatchcase(name, pattern.replace("IMAGE", ending[1:]))
               for pattern in patterns for ending in (IMAGE_SUFFIXES if "IMAGE" in pattern else (".",)))


def _arrays_hold_light_field(shapes: Optional[list]) -> Optional[bool]:
    """From stored shapes: whether one of them is 4-D or 5-D (None: unknown)."""
    return None if shapes is None else any(len(shape) in (4, 5) for shape in shapes)


def _views_folder(names: Sequence[str]) -> bool:
    """At least two images whose names carry view indices (one alone is a picture)."""
    return len(view_names(names)) >= 2


#: every light field format, in the order a path is matched against them
FORMATS: Dict[str, InputFormat] = {f.name: f for f in (
    InputFormat("hci", "HCI 4D benchmark scene", ("input_CamNNN.png",),
                read_hci_light_field, folder=True, folder_test=is_hci_scene, fuzz=(None, {})),
    InputFormat("views", "folder of views named by row and column (scene_RR_CC.png)",
                ("scene_RR_CC.IMAGE",), read_views, ("grid", "pattern"), folder=True,
                folder_test=_views_folder, fuzz=(None, {})),
    InputFormat("npy", "numpy array (T, S, V, U[, C])", ("*.npy",), read_numpy,
                holds_light_field=lambda path: _arrays_hold_light_field(stored_shapes(path)),
                fuzz=(".npy", {})),
    InputFormat("npz", "numpy arrays, the light field as light_field or the only array",
                ("*.npz",), read_numpy, ("key",),
                holds_light_field=lambda path: _arrays_hold_light_field(stored_shapes(path)),
                fuzz=(".npz", {})),
    InputFormat("mat", "MATLAB file (Light Field Toolbox, HCI tools), variable LF",
                ("*.mat",), read_mat, ("key",), holds_light_field=mat_holds_light_field,
                fuzz=(".mat", {})),
    InputFormat("hdf5", "HDF5 file (2013 HCI benchmark), dataset LF", ("*.h5", "*.hdf5", "*.hdf"),
                read_hdf5, ("key",),
                holds_light_field=lambda path: _arrays_hold_light_field(dataset_shapes(path)),
                fuzz=(".h5", {})),
    InputFormat("eslf", "lenslet image (ESLF: Stanford Lytro archive, Light Field Toolbox)",
                ("*.eslf.IMAGE", "*.eslf.*.IMAGE", "*_eslf.IMAGE"), read_eslf, ("n", "keep"),
                fuzz=(".eslf.png", {"n": 2})),
    InputFormat("mosaic", "one image of T x S sub-aperture tiles", (), read_mosaic, ("grid",),
                fuzz=(".png", {"grid": (2, 2)})),
)}


def format_named(name: str, source: str) -> InputFormat:
    """The format called ``name``, or a ValueError naming ``source`` and the formats."""
    if name not in FORMATS:
        raise ValueError(f"{source}: unknown format {name!r}; expected one of: "
                         f"{accepted_formats()}")
    return FORMATS[name]


def guess_format(path: Union[str, os.PathLike]) -> Optional[str]:
    """The format :func:`liff.io.read_light_field` would pick for ``path`` by its name
    (a folder: by the names of its files; any other folder is ``views``), or None."""
    path = os.fspath(path)
    if os.path.isdir(path):
        try:
            names = os.listdir(path)
        except OSError:
            names = []
        return "hci" if FORMATS["hci"].recognises(path, names) else "views"
    return next((f.name for f in FORMATS.values() if not f.folder and f.recognises(path)), None)


def how_recognised(fmt: InputFormat) -> str:
    """How a path is recognised as ``fmt``, in words (docs, errors)."""
    if not fmt.names:
        return f"only when named (format='{fmt.name}', --format {fmt.name})"
    shown = ", ".join(f"`{n.replace('IMAGE', 'png')}`" for n in fmt.names)
    if any("IMAGE" in n for n in fmt.names):
        shown += " (or another image ending)"
    if fmt.name == "views":
        return "a folder of two or more images whose names carry the view's row and column"
    return f"a folder holding {shown}" if fmt.folder else shown


def accepted_formats() -> str:
    """Every format with how it is recognised, for error messages."""
    return "; ".join(f"{f.name}: {how_recognised(f)}".replace("`", "") for f in FORMATS.values())


def formats_table() -> str:
    """The table of formats docs/INPUTS.md shows (Markdown): name, what it is, how it is
    recognised, its options (the keyword and the flag)."""
    rows = ["| format | what | recognised by | options |", "| --- | --- | --- | --- |"]
    for f in FORMATS.values():
        options = ", ".join(f"`{k}` (`{OPTIONS[k].flag}`)" for k in f.options) or "-"
        rows.append(f"| `{f.name}` | {f.what} | {how_recognised(f)} | {options} |")
    return "\n".join(rows)


def formats_taking(keyword: str) -> Tuple[str, ...]:
    """The formats that take the option ``keyword``."""
    return tuple(f.name for f in FORMATS.values() if keyword in f.takes())


def flag_help(option: ReaderOption) -> str:
    """The command line's help of an option: what it sets and the formats it applies to."""
    takers = formats_taking(option.keyword)
    where = "every format" if len(takers) == len(FORMATS) else ", ".join(takers)
    return f"{option.help} (applies to: {where})"


def format_help() -> str:
    """``--format``'s help: every format and how it is recognised."""
    return ("the light field format (default: from each input's names and content): " +
            "; ".join(f"{f.name}: {f.what}" for f in FORMATS.values()))
