"""What a folder holds: the light fields in it, each recognised by its names and content.

:func:`walk` expands a dataset folder of any mix, entry by entry, with the formats of
the registry (:mod:`liff.io.formats`):

- a folder whose images carry view indices (two or more: ``scene_RR_CC.png``), or an
  HCI scene (``input_CamNNN.png``), is one light field; its other images are the
  scene's (masks, ground truth), while its light field files and sub-folders are
  walked as well;
- a file named as a format (``*.npz``, ``*.mat``, ``*.h5``, ``*.eslf.png``, ...) is that
  format, if its content (headers only) can hold a light field: a 4-D or 5-D array;
- any other image in a folder without views is a lenslet image (``eslf``; the Stanford
  Lytro archive's plain names), its lenslet size detected when it is read;
- what liff writes beside its outputs (``liff synth``'s ``*.slopes.npy`` and
  ``*.truth.json``, run manifests, feature files) is never an input;
- hidden names are skipped, sub-folders walked at any depth, links back up ignored.

What a quoted glob pattern matches goes through the same rules (:func:`expand_match`).

With a format given (``--format``), only what that format reads is taken. A path given
by itself goes through the same rules (:func:`classify`).
"""

from __future__ import annotations

import fnmatch
import os
import shlex
import warnings
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

from .._paths import special_kind
from .._warnings import LiffWarning
from .formats import FORMATS, InputFormat
from .images import IMAGE_SUFFIXES
from .views import view_names

#: names liff writes beside its outputs, never inputs (``liff synth``'s ground truth,
#: ``liff detect``'s manifests)
SIDECARS = ("*.slopes.npy", "*.truth.json", "manifest-*.csv")
#: the format of an image no other rule claims, in a folder without views
LENSLET = "eslf"


@dataclass(frozen=True)
class Entry:
    """A path and what it was taken as.

    Attributes
    ----------
    path : str
        The file or folder.
    format : str or None
        The format it is read as; None: not an input (``why`` says what it is), or, for
        a path given by itself, a format the names cannot tell (the reader says so).
    why : str
        How it was recognised, or why it is not an input.
    """

    path: str
    format: Optional[str]
    why: str

    @property
    def is_input(self) -> bool:
        return not self.why.startswith("not an input")


def _not_input(path: str, why: str) -> Entry:
    return Entry(path, None, f"not an input: {why}")


class UnlistedFolder(ValueError):
    """A folder that cannot be listed (a sub-folder of a walk is skipped, said so)."""


def _listing(folder: str) -> List[str]:
    """The folder's names but hidden ones, sorted (ValueError naming an unreadable one)."""
    try:
        with os.scandir(folder) as entries:
            return sorted(e.name for e in entries if not e.name.startswith("."))
    except OSError as error:
        raise UnlistedFolder(f"{folder}: cannot list the folder ({error.strerror}); expected a "
                         "readable folder of light fields or of views") from None


def folder_format(folder: str, names: Sequence[str], format: Optional[str] = None,
                  pattern: Optional[str] = None) -> Optional[Entry]:
    """The entry of ``folder`` if it is one light field (HCI scene, views), else None.
    ``pattern`` (``--pattern``): view names matched whole instead of the default rule.

    Raises
    ------
    ValueError
        If ``pattern`` is not a views pattern, or matches none of the names of a folder
        the default rule takes as views (its images are not lenslet images).
    """
    if format in (None, "hci") and FORMATS["hci"].recognises(folder, names):
        return Entry(folder, "hci", "HCI scene: input_CamNNN.png views")
    if format not in (None, "views"):
        return None
    views = view_names(names, pattern)
    if pattern and not views:
        by_default = view_names(names)
        if len(by_default) >= 2:
            raise ValueError(f"no file in {folder} matches --pattern {shlex.quote(pattern)}; expected a "
                             f"pattern the names of its views match whole (such as "
                             f"{by_default[0]})")
    if len(views) >= (1 if pattern else 2):
        return Entry(folder, "views", f"views: {len(views)} images named by row and column"
                     + (" (--pattern)" if pattern else "") + f", e.g. {views[0]}")
    return None


#: the ``why`` of an entry that is a feature file of ``liff detect`` (features=True)
FEATURE_FILE = "liff feature file"


def classify(path: str, format: Optional[str] = None, in_views: bool = False,
             features: bool = False) -> Entry:
    """What the file ``path`` is: an input of some format, or not an input (and why).
    ``in_views``: it lies in a folder of views, whose images are that light field's;
    ``features``: liff feature files are inputs too (``liff colmap``, ``liff sfm``)."""
    name = os.path.basename(path).lower()
    if any(fnmatch.fnmatchcase(name, pattern) for pattern in SIDECARS):
        return _not_input(path, "written by liff beside its outputs (ground truth, manifest)")
    if features and name.endswith(".npz") and special_kind(path) is None and is_feature_file(path):
        return Entry(path, None, FEATURE_FILE)
    by_name = next((f for f in FORMATS.values() if not f.folder and f.recognises(path)), None)
    image = name.endswith(IMAGE_SUFFIXES)
    if format is not None:
        wanted = FORMATS[format]
        if wanted.folder:
            return _not_input(path, f"a file, and --format {format} reads folders")
        if by_name is not None and by_name is not wanted or (by_name is None and not image):
            return _not_input(path, f"not named as {format}")
        return _content_checked(path, wanted, f"--format {format}")
    if by_name is not None:
        return _content_checked(path, by_name, f"named {by_name.names[0].replace('IMAGE', '<image>')}")
    if image and not in_views:
        return Entry(path, LENSLET, "lenslet image: an image not named as a view, in a folder "
                     "without views (lenslet size detected when read)")
    if image:
        return _not_input(path, "an image of the folder of views it lies in")
    return _not_input(path, "not a light field name")


def _content_checked(path: str, fmt: InputFormat, why: str) -> Entry:
    """``fmt``'s entry for ``path``, unless its content shows it holds no light field."""
    if special_kind(path) is not None:  # a FIFO would block: the reader refuses it unopened
        return Entry(path, fmt.name, why)
    holds = fmt.holds_light_field(path) if fmt.holds_light_field is not None else None
    if holds is False:
        return _not_input(path, f"a {fmt.name} file holding no 4-D or 5-D array (a liff "
                          "feature file, a slope map, ...)")
    return Entry(path, fmt.name, why)


def is_feature_file(path: str) -> bool:
    """Whether ``path`` is a feature file of ``liff detect`` (members ``keypoints`` and
    ``descriptors``), from the zip's list of members alone."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as archive:
            return {"keypoints.npy", "descriptors.npy"} <= set(archive.namelist())
    except (OSError, zipfile.BadZipFile):
        return False


def walk(folder: str, format: Optional[str] = None, pattern: Optional[str] = None,
         features: bool = False, _seen: Optional[set] = None) -> List[Entry]:
    """Every entry of a folder taken as an input or seen and left out, at any depth (see
    the module's docstring): the folder itself if it is one light field, its files, and
    its sub-folders' entries, in name order.

    ``features``: liff feature files are inputs too.

    Raises
    ------
    ValueError
        If ``folder`` cannot be listed (an unreadable sub-folder is skipped with a
        LiffWarning).
    """
    seen = _seen if _seen is not None else set()
    if os.path.realpath(folder) in seen:  # a link back up: a cycle
        return []
    seen.add(os.path.realpath(folder))
    names = _listing(folder)
    itself = folder_format(folder, names, format, pattern)
    found: List[Entry] = [itself] if itself is not None else []
    for path in (os.path.join(folder, n) for n in names):
        if os.path.isdir(path):
            try:
                found += walk(path, format, pattern, features, seen)
            except UnlistedFolder as error:  # an unreadable sub-folder (lost+found): the rest go on
                warnings.warn(f"{error}; skipped", LiffWarning, stacklevel=2)
        elif itself is None or not _is_view(path):
            found.append(classify(path, format, itself is not None, features))
    return found


def _is_view(path: str) -> bool:
    """Whether ``path``, in a folder that is one light field, is one of its images (a
    lenslet image's name says it is not)."""
    return path.lower().endswith(IMAGE_SUFFIXES) and not FORMATS["eslf"].recognises(path)


def through_link_back_up(path: str) -> Optional[str]:
    """The part of ``path`` that is a link to a folder holding it (``selfloop -> .``):
    ``path`` reached through it repeats its folder; None if there is none."""
    parts = os.path.normpath(path).split(os.sep)
    for i in range(1, len(parts) + 1):
        part = os.sep.join(parts[:i]) or os.sep
        if os.path.islink(part) and os.path.isdir(part):
            target = os.path.realpath(part)
            holder = os.path.realpath(os.path.dirname(part) or ".")
            if holder == target or holder.startswith(target.rstrip(os.sep) + os.sep):
                return part
    return None


def expand_match(path: str, format: Optional[str] = None, pattern: Optional[str] = None,
                 features: bool = False, folders: Optional[dict] = None
                 ) -> Tuple[List[Entry], List[Entry]]:
    """(inputs, entries left out) of a path a glob pattern matched: by the rules of a
    folder walk, not as a path given by itself. A folder is walked; a file is what it
    would be in its folder's walk: liff's sidecars are left out, and an image of a
    folder that is one light field stands for that folder; a path reached through a
    link to a folder holding it (a loop) is left out.

    ``folders``: {folder: its entry or None}, kept between the matches of one pattern
    (each folder is listed once)."""
    folders = {} if folders is None else folders
    loop = through_link_back_up(path)
    if loop is not None:
        entries = [_not_input(path, f"reached through {loop}, a link to a folder holding it")]
    elif os.path.isdir(path):
        entries = walk(path, format, pattern, features)
    else:
        folder = os.path.dirname(path) or "."
        if folder not in folders:
            folders[folder] = folder_format(folder, _listing(folder), format, pattern)
        itself = folders[folder]
        entries = [itself if itself is not None and _is_view(path)
                   else classify(path, format, itself is not None, features)]
    return [e for e in entries if e.is_input], [e for e in entries if not e.is_input]


def expand(path: str, format: Optional[str] = None, pattern: Optional[str] = None,
           features: bool = False) -> Tuple[List[Entry], List[Entry]]:
    """(inputs, entries left out) of a path given by the user: a folder is walked; a
    file is classified as it would be in a folder of its own; a path that does not
    exist is an input of no format (its reader says so)."""
    if os.path.isdir(path):
        entries = walk(path, format, pattern, features)
    elif os.path.exists(path):
        entry = classify(path, format, features=features)
        # a file given by itself is an input even where a walk would leave it out
        entries = [entry if entry.is_input else Entry(path, format, "given")]
    else:
        entries = [Entry(path, format, "given")]
    return [e for e in entries if e.is_input], [e for e in entries if not e.is_input]
