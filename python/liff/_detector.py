"""The Python face of the detector: cv2 types in, cv2 types out."""

from __future__ import annotations

import functools
import inspect
import math
import os
import textwrap
import warnings
from typing import List, NamedTuple, Optional, Tuple, Union, cast

import cv2
import numpy as np

from . import _core
from ._warnings import LiffWarning, SlopeRangeWarning
from .keypoint_rows import KeyPoints, keypoints_to_rows, rows_to_keypoints

RANGE_END_SHARE: float = _core.RANGE_END_SHARE
"""A hand-set slope range warns when more than this share of features sit at its ends
(the core's kRangeEndShare, liff/liff.hpp: past it, the core surveys for structure beyond)."""
SMALL_REACH: float = _core.SMALL_REACH
"""Below this largest automatic slope (pixels per view step), finding no feature is
worth a warning: scenes often reach beyond it (camera arrays, gantries; the core's
kSmallReach, liff/liff.hpp)."""


@functools.lru_cache(maxsize=None)
def _cv2_returns_empty_descriptors() -> bool:
    """Whether the installed cv2 returns an empty (0, 128) array, rather than None, as
    the descriptors of an image with no features: OpenCV 5 does, 4.x returns None.
    Probed once on cv2.SIFT, so liff follows whichever cv2 the caller has."""
    _, descriptors = cv2.SIFT.create().detectAndCompute(np.zeros((16, 16), np.uint8), None)
    return descriptors is not None


class Parameter(NamedTuple):
    """One detector parameter, as defined once in C++ (``liff/parameters.hpp``)."""

    name: str     # create() keyword, OpenCV's spelling
    type: type    # int, float or bool
    default: object
    accessor: str  # getter/setter suffix: get<accessor>(), set<accessor>(value)
    help: str     # meaning, unit and range


PARAMETERS: Tuple[Parameter, ...] = tuple(
    Parameter(name, {"int": int, "float": float, "bool": bool}[kind], default, accessor, text)
    for name, kind, default, accessor, text in _core.PARAMETERS)
"""Every detector parameter, in ``create()``'s positional order."""

_SIGNATURE = inspect.Signature([
    inspect.Parameter(p.name, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=p.default,
                      annotation=p.type.__name__) for p in PARAMETERS])


def _parameters_docstring() -> str:
    """The numpydoc Parameters section of :class:`LiFF`, from :data:`PARAMETERS`."""
    lines = ["Parameters", "----------"]
    for p in PARAMETERS:
        default = "cv2.CV_32F" if p.name == "descriptorType" else repr(p.default)
        lines.append(f"{p.name} : {p.type.__name__}, default {default}")
        lines += textwrap.wrap(f"{p.help[0].upper()}{p.help[1:]}.", 80, initial_indent="    ",
                               subsequent_indent="    ")
    return "\n".join("    " + line if line else line for line in lines)


def _is_list_of_inputs(lf) -> bool:
    """cv2's list semantics: a list or tuple whose items are all arrays (or cv2.UMat)
    is several inputs, each a light field or an image, detected on its own (as
    ``cv2.SIFT.detect([img1, img2])``); nested Python lists stay one array."""
    return isinstance(lf, (list, tuple)) and all(
        isinstance(item, (np.ndarray, cv2.UMat)) for item in lf)


def _per_input(items, count: int, what: str) -> list:
    """``items`` (None, or a list of one per input) as a list of ``count`` items."""
    if items is None:
        return [None] * count
    if not isinstance(items, (list, tuple)) or len(items) != count:
        got = f"{len(items)} items" if isinstance(items, (list, tuple)) else type(items).__name__
        raise ValueError(f"{what}: expected a list of {count} (one per input), got {got}")
    return list(items)


def _as_light_field(lf) -> np.ndarray:
    """C-contiguous, native-byte-order view (or copy) of ``lf``; never modifies it.
    TypeError for None (what a failed read such as cv2.imread returns)."""
    if lf is None:
        raise TypeError("light field is None; expected an array (T, S, V, U[, C]) or one "
                        "view (V, U[, C]) (did a read fail? cv2.imread returns None)")
    if isinstance(lf, (str, bytes, os.PathLike)):
        raise ValueError(f"light field is a {type(lf).__name__} ({lf!r}), not an array of a "
                         "numeric dtype; expected an array of uint8, uint16, float32 or float64 "
                         "(a file is read with liff.io.read_light_field(path).light_field)")
    if not isinstance(lf, np.ndarray):
        if hasattr(lf, "get") and callable(lf.get):  # cv2.UMat
            lf = lf.get()
        try:
            lf = np.asarray(lf)
        except ValueError as error:  # nested sequences of differing shapes
            raise ValueError(f"light field is a {type(lf).__name__} that is no array ({error}); "
                             "expected an array (T, S, V, U[, C]) or one view (V, U[, C]), or "
                             "a list of such arrays (one input each)") from None
    if lf.dtype.kind == "b":
        raise ValueError("light field dtype is bool; expected uint8, uint16, float32 or float64")
    lf = as_read_in_place(lf)
    # Warn (never fail) when the values do not fill the range the dtype is read on.
    # lazy: defers loading liff.io (the package of every reader) to the first detection, so
    # that `import liff` stays without the readers (liff/__init__.py)
    from .io.intensity import check_intensity

    check_intensity(lf, stacklevel=4)
    _check_axis_order(lf)
    return lf


def _check_axis_order(lf: np.ndarray) -> None:
    """Warns (LiffWarning) when a light field has more views than pixels per view along
    both axes: real captures never do, an array in (V, U, T, S) order does (it detects
    nothing in views of a few pixels, silently otherwise)."""
    if lf.ndim not in (4, 5):
        return
    T, S, V, U = lf.shape[:4]
    if V < T and U < S:
        warnings.warn(f"light field has shape {lf.shape}: {T}x{S} views of {U}x{V} pixels, more "
                      "views than pixels per view along both axes; check the axis order: "
                      "expected (T, S, V, U[, C]) = (view row, view column, pixel row, pixel "
                      "column[, channel])", LiffWarning, stacklevel=4)


def as_read_in_place(lf: np.ndarray) -> np.ndarray:
    """``lf`` itself if the core reads it in place (C-contiguous, native byte order),
    else such a copy: what detection copies first, which a caller bounding memory
    (liff.batch) makes before the detector's memory limit is set, so that it counts."""
    if not lf.dtype.isnative:  # (one copy, in C order)
        return lf.astype(lf.dtype.newbyteorder("="), order="C")
    # (np.ascontiguousarray would turn a 0-d array into shape (1,).)
    return lf if lf.flags.c_contiguous else np.ascontiguousarray(lf)


def _as_mask(mask) -> Optional[np.ndarray]:
    if mask is None:
        return None
    mask = np.asarray(mask)
    if mask.dtype == np.bool_:
        mask = mask.astype(np.uint8)
    return mask if mask.flags.c_contiguous else np.ascontiguousarray(mask)


def _copy_scalars(node: "cv2.FileNode", fs: "cv2.FileStorage") -> None:
    """Writes the string, int and real entries of the map ``node`` that LiFF reads (its
    parameters and ``name``) into ``fs`` (other keys may be names cv2's writer refuses)."""
    read = {p.name for p in PARAMETERS} | {"name"}
    for key in node.keys():
        if key not in read:
            continue
        child = node.getNode(key)
        if child.isString():
            fs.write(key, child.string())
        elif child.isInt():
            # cv2 may hold a 64-bit integer, and its write() takes a C int (it wrote
            # 4294967297 as `true`): one beyond an int goes as a real, which read() refuses
            value = int(child.real())
            fs.write(key, value if -2**31 <= value < 2**31 else float(value))
        elif child.isReal():
            fs.write(key, child.real())


class LiFF(_core.LiFF):
    """Light field features in scale and depth, a drop-in for ``cv2.SIFT``.

    {parameters}

    Notes
    -----
    Light fields are numpy arrays of shape ``(T, S, V, U)`` or ``(T, S, V, U, C)``
    (view row, view column, pixel row, pixel column, channel), C = 1 (grey), 2 (grey +
    alpha), 3 (BGR, as OpenCV) or 4 (BGRA), dtype uint8 (/255), uint16 (/65535), float32
    or float64 (taken as given, nominally in [0, 1]). An alpha channel is a per-sample
    validity weight ``a >= 0`` (e.g. a Lytro lenslet image's vignetting mask): the
    focal stack becomes ``sum(a L) / sum(a)``. A 2-D image ``(V, U)`` or ``(V, U, C)``
    is a 1x1 light field, for which LiFF behaves as SIFT. Slopes are in pixels per view
    step with the sign of HCI disparity; docs/CONVENTIONS.md has every convention.

    The method is the paper's (below): a focal stack over the slopes (Sec. 3.2, eq. 8),
    SIFT's DoG scale space of each focal slice, extrema over all 80 neighbours in
    (x, y, scale, slope) (Sec. 3.1), and each descriptor on the slice of its slope
    (Sec. 3.3). What liff adds or changes is in the README's *How it works*.

    References
    ----------
    .. [1] D. G. Dansereau, B. Girod and G. Wetzstein, "LiFF: Light Field Features in
       Scale and Depth", CVPR 2019. arXiv:1901.03916, doi:10.48550/arXiv.1901.03916.
    .. [2] D. G. Lowe, "Distinctive Image Features from Scale-Invariant Keypoints", IJCV
       60(2), 2004, doi:10.1023/B:VISI.0000029664.99615.94.

    Examples
    --------
    >>> import cv2, liff
    >>> from liff import synthetic
    >>> shape = (5, 5, 96, 96)  # (T, S, V, U)
    >>> blobs = synthetic.random_blob_layers([-0.5, 0.5], shape, blobs_per_layer=4, seed=0)
    >>> lf = synthetic.render_disks(blobs, shape, profile="gaussian")
    >>> detector = liff.LiFF.create()  # was: cv2.SIFT.create()
    >>> keypoints, descriptors = detector.detectAndCompute(lf)
    >>> descriptors.shape[1], descriptors.dtype
    (128, dtype('float32'))
    >>> slopes = liff.keypoint_slopes(keypoints)  # one per keypoint, pixels per view step
    >>> bool(abs(sorted(slopes)[0] + 0.5) < 0.1 and abs(sorted(slopes)[-1] - 0.5) < 0.1)
    True
    """

    def __init__(self, *args, **kwargs) -> None:
        """Creates a detector; arguments as :meth:`create`."""
        super().__init__(**_bind(args, kwargs))
        self._initialised = True  # (a raising __init__ leaves no C++ object: see __repr__)

    @classmethod
    def create(cls, *args, **kwargs) -> "LiFF":
        """Creates a detector: positional arguments in cv2.SIFT's order, then LiFF's
        (see the class's Parameters). Raises TypeError for an unknown keyword or a value
        of the wrong type, ValueError for one out of range."""
        return cls(*args, **kwargs)

    def slopesFor(self, *args) -> List[float]:
        """The slopes of the focal slices, pixels per view step, increasing.

        ``slopesFor(T, S)``: for a light field of T x S views with a finite slope range
        (raises ValueError with an automatic one, whose slopes depend on the content).
        ``slopesFor(lf)``: those detection would build for the light field ``lf``; with
        an automatic range this runs its survey (docs/SLOPES.md), 13-44% of a detection
        in benchmarks/slopes.py (the most on small light fields). Neither changes
        :meth:`getSlicesUsed` and :meth:`getSearchedSlopes`, which describe the last
        detect, detectAndCompute or compute call.

        Raises
        ------
        ValueError
            ``slopesFor(T, S)`` with an automatic range, or a bad light field.
        TypeError
            One number (view counts come in pairs, ``slopesFor(T, S)``).
        """
        if len(args) == 1:
            if isinstance(args[0], (int, float, np.integer, np.floating)):
                raise TypeError(f"slopesFor({args[0]!r}): expected slopesFor(T, S), two view "
                                "counts, or slopesFor(lf), a light field")
            return self._slopes_for_light_field(_as_light_field(args[0]))
        return super().slopesFor(*args)

    def detect(self, lf, mask=None, masks=None) -> Union[KeyPoints, Tuple[KeyPoints, ...]]:
        """Detects keypoints.

        Parameters
        ----------
        lf : array_like, shape (T, S, V, U[, C]) or (V, U[, C]); or a list of them
            The light field (see the class notes). A list or tuple of arrays is several
            inputs, as ``cv2.SIFT.detect([img1, img2])`` takes them: each is detected on
            its own, and a tuple of keypoint tuples comes back, one per input.
        mask : ndarray of uint8 or bool, shape (V, U), optional
            Keep keypoints whose centre-view pixel is non-zero. For a list of inputs, a
            list of masks (None items allowed), also accepted as ``masks`` (cv2's name).

        Returns
        -------
        keypoints : tuple of cv2.KeyPoint (a tuple of them per input for a list)
            ``pt`` in centre-view pixels, ``size`` a diameter, ``angle`` in degrees,
            ``response`` the |DoG| contrast, ``octave`` packed as cv2.SIFT, slope in
            ``class_id`` (see :func:`keypoint_slopes`).

        Raises
        ------
        ValueError
            For a list of masks whose length differs from the inputs'.
        """
        if masks is not None:
            if mask is not None:
                raise TypeError("detect(): give mask or masks, not both")
            mask = masks
        if _is_list_of_inputs(lf):
            per_input = _per_input(mask, len(lf), "masks")
            return tuple(cast(KeyPoints, self.detect(item, m)) for item, m in zip(lf, per_input))
        array = _as_light_field(lf)
        rows, _ = self._run(array, _as_mask(mask), None, False)
        self._check_range_ends(array, rows, mask is not None)
        return rows_to_keypoints(rows)

    def compute(self, lf, keypoints, descriptors=None
                ) -> Union[Tuple[KeyPoints, Optional[np.ndarray]],
                           Tuple[Tuple[KeyPoints, ...], Tuple[Optional[np.ndarray], ...]]]:
        """Describes the given keypoints, each on the focal slice nearest its slope.

        Every keypoint keeps its place, as with ``cv2.SIFT.compute``: one that cannot
        be described (a packed octave/layer the light field's pyramid lacks, a NaN or
        huge position, ``size <= 0``, a NaN angle) gets an all-zero descriptor, so
        arrays aligned with the keypoints stay aligned.

        Returns
        -------
        keypoints : tuple of cv2.KeyPoint
            The keypoints given, in their order.
        descriptors : ndarray, shape (N, 128), float32 (or uint8)
            For N == 0, what the installed cv2 returns: an empty (0, 128) array with
            OpenCV 5, None with OpenCV 4.
        """
        if _is_list_of_inputs(lf):
            per_input = _per_input(keypoints, len(lf), "keypoint lists")
            if len(lf) and any(k is None for k in per_input):
                raise TypeError("compute() of a list of inputs takes a list of keypoint "
                                "lists, one per input (as cv2.SIFT.compute)")
            results = [self._compute_one(item, k) for item, k in zip(lf, per_input)]
            return tuple(k for k, _ in results), tuple(d for _, d in results)
        return self._compute_one(lf, keypoints)

    def _compute_one(self, lf, keypoints) -> Tuple[KeyPoints, Optional[np.ndarray]]:
        """:meth:`compute` of one input."""
        rows = keypoints_to_rows(keypoints)
        rows, desc = self._run(_as_light_field(lf), None, rows, True)
        return rows_to_keypoints(rows), self._descriptors_out(desc, len(rows))

    def detectAndCompute(
        self, lf, mask=None, descriptors=None, useProvidedKeypoints: bool = False
    ) -> Tuple[KeyPoints, Optional[np.ndarray]]:
        """Detects keypoints and computes their 128-D descriptors.

        Parameters
        ----------
        lf : array_like, shape (T, S, V, U[, C]) or (V, U[, C])
        mask : ndarray of uint8 or bool, shape (V, U), optional

        Returns
        -------
        keypoints : tuple of cv2.KeyPoint
        descriptors : ndarray, shape (N, 128), float32 (or uint8)
            For N == 0, as ``cv2.SIFT.detectAndCompute`` of the installed cv2: an
            empty (0, 128) array with OpenCV 5, None with OpenCV 4.
        """
        if useProvidedKeypoints:
            raise ValueError("useProvidedKeypoints=True: call compute(lf, keypoints) instead")
        if _is_list_of_inputs(lf):
            raise TypeError(f"detectAndCompute() takes one light field or image, not a list "
                            f"of {len(lf)} arrays (nor does cv2.SIFT.detectAndCompute); call "
                            "it on each, or detect() and compute() with the list")
        array = _as_light_field(lf)
        rows, desc = self._run(array, _as_mask(mask), None, True)
        self._check_range_ends(array, rows, mask is not None)
        return rows_to_keypoints(rows), self._descriptors_out(desc, len(rows))

    def _descriptors_out(self, descriptors: Optional[np.ndarray], count: int
                         ) -> Optional[np.ndarray]:
        """The descriptors as cv2.SIFT would return them; with none, the installed cv2's
        empty value (:func:`_cv2_returns_empty_descriptors`)."""
        if count:
            return descriptors
        if not _cv2_returns_empty_descriptors():
            return None
        dtype = np.uint8 if self.descriptorType() == cv2.CV_8U else np.float32
        return np.empty((0, self.descriptorSize()), dtype)

    def _check_range_ends(self, lf: np.ndarray, rows: np.ndarray, masked: bool = False) -> None:
        """The range warnings, from the core's report of the call
        (:meth:`getSlopeRangeReport`): where the survey saw structure at or beyond the
        largest slope an automatic end considers, R (of a half-automatic range too), that
        slopes beyond R are not searched; :meth:`_check_pinned_ends`; with an automatic
        range and no feature, that slopes beyond R are not searched
        (docs/SLOPES.md, "Bound"): where R is small (under SMALL_REACH), the views are
        large enough to survey, no mask was given and the light field is not constant;
        and with an automatic range whose survey found nothing in a light field that is
        not constant, that the paper's [-1, 1] was searched ("Nothing found")."""
        report = self.getSlopeRangeReport()
        T, S, V, U = report.T, report.S, report.V, report.U
        reach = report.automaticReach  # NaN: no survey, nothing to warn of
        if report.structureBeyondReach:  # at an automatic end, of a half-automatic range too
            warnings.warn(f"the automatic slope range considers slopes within +-{reach:.2f} "
                          f"for {T}x{S} views of {U}x{V} (docs/SLOPES.md, 'Bound'), and its "
                          f"survey saw structure at or beyond that: features there may be "
                          f"missed or reported at wrong slopes ({len(rows)} features "
                          "returned); set firstSlope and lastSlope to search beyond",
                          SlopeRangeWarning, stacklevel=3)
            return
        if not report.automaticRange:
            self._check_pinned_ends(report, len(rows))  # a finite end: features pinned there?
            return
        if lf.ndim < 4:  # one view: one slice, no range
            return
        if not len(rows):
            if reach < SMALL_REACH and min(V, U) >= 64 and not masked and np.ptp(lf) > 0:
                warnings.warn(f"no features with the automatic slope range, which considers "
                              f"slopes within +-{reach:.2f} for {T}x{S} views of {U}x{V} "
                              "(docs/SLOPES.md, 'Bound'); if the scene's slopes reach "
                              "beyond, set firstSlope and lastSlope",
                              SlopeRangeWarning, stacklevel=3)
                return
        if report.surveyFoundNothing and np.ptp(lf) > 0:
            # A light field that is not constant, in which the survey found no structure
            # (noise, low contrast, mostly invalid samples): the paper's range was searched.
            warnings.warn(f"the automatic slope range's survey found no structure in this "
                          f"light field (noise, low contrast or mostly invalid alpha?), so "
                          f"the paper's [-1, 1] was searched ({len(rows)} features); "
                          "features at slopes beyond are missed or reported at its ends: if "
                          "the scene's slopes reach beyond, set firstSlope and lastSlope",
                          SlopeRangeWarning, stacklevel=3)

    def _check_pinned_ends(self, report, count: int) -> None:
        """Warns (SlopeRangeWarning) when more than RANGE_END_SHARE of the ``count``
        features sit at a hand-set end of the slope range (firstSlope or lastSlope finite)
        and the automatic survey (docs/SLOPES.md), which the core then ran, finds
        structure beyond that end: their slopes are pinned there. Features at an end the
        scene itself ends at are not warned about."""
        first, last = self.getFirstSlope(), self.getLastSlope()
        if not report.endsSurveyed:  # few features at the ends (the core counted them)
            return
        low, high = report.featuresAtFirstSlope, report.featuresAtLastSlope
        searched = report.searchedSlopes
        # Structure beyond an end: a share of the survey's features (not one outlier)
        # nearer a slice past the end than the end slice itself.
        surveyed = np.asarray(report.surveyedSlopes)
        half = (searched[1] - searched[0]) / 2
        if not len(surveyed) or not (
                (low and np.mean(surveyed < first - half) > RANGE_END_SHARE) or
                (high and np.mean(surveyed > last + half) > RANGE_END_SHARE)):
            return
        found = (float(np.percentile(surveyed, 1)), float(np.percentile(surveyed, 99)))
        suggested = ", ".join(
            [f"firstSlope={min(first, found[0]):.2f}"] * math.isfinite(first) +
            [f"lastSlope={max(last, found[1]):.2f}"] * math.isfinite(last))
        warnings.warn(f"{low + high} of {count} features ({100 * (low + high) / count:.0f}%) "
                      f"sit at an end of the slope range [{first:g}, {last:g}] and the light "
                      f"field has structure beyond it (slopes {found[0]:.2f} to {found[1]:.2f}), "
                      f"whose features are reported at the end; try {suggested}, or the "
                      f"automatic range (firstSlope=-inf, lastSlope=+inf, the default)",
                      SlopeRangeWarning, stacklevel=3)

    # --- persistence, as cv2.Feature2D -----------------------------------------
    def save(self, filename: Union[str, os.PathLike]) -> None:
        """Writes the parameters to ``filename`` (.yml, .yaml, .xml or .json)."""
        self._save(os.fspath(filename))

    def write(self, fs, name: Optional[str] = None) -> None:
        """Writes the parameters to a path, or into an open ``cv2.FileStorage``.

        With a FileStorage and ``name``, the parameters go in a map of that name;
        without ``name``, at the current level.
        """
        if isinstance(fs, (str, os.PathLike)):
            self.save(fs)
            return
        if not isinstance(fs, cv2.FileStorage):
            raise TypeError(f"write() got {type(fs).__name__}; expected a path or cv2.FileStorage")
        source = cv2.FileStorage(self._to_string(), cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
        if name is not None:
            fs.startWriteStruct(name, cv2.FILE_NODE_MAP)
        _copy_scalars(source.root(), fs)
        if name is not None:
            fs.endWriteStruct()

    def read(self, source) -> None:
        """Reads parameters from a path or a ``cv2.FileNode`` (written by save/write).

        Raises ValueError if the file cannot be read or a value is out of range; the
        detector is unchanged then. A path must be a regular file of at most 1 MiB nested
        at most 64 levels deep (docs/RELIABILITY.md), checked before OpenCV parses it.
        """
        if isinstance(source, (str, os.PathLike)):
            path = os.fspath(source)
            if not os.path.exists(path):
                raise ValueError(f"cannot read LiFF parameters: no file '{path}'")
            try:
                self._read_file(path)  # refuses anything but a regular file
            except ValueError as error:  # (a value out of range: name the file too)
                if path in str(error):
                    raise
                raise ValueError(f"{path}: {error}") from None
            return
        if not isinstance(source, cv2.FileNode):
            raise TypeError(f"read() got {type(source).__name__}; expected a path or cv2.FileNode")
        node = source
        if node.isMap() and not node.getNode(self.getDefaultName()).empty():
            node = node.getNode(self.getDefaultName())
        if not node.isMap():
            raise ValueError("read() expected a map of LiFF parameters")
        copy = cv2.FileStorage(".yml", cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY)
        _copy_scalars(node, copy)
        self._from_string(copy.releaseAndGetString())

    def __repr__(self) -> str:
        if not self.__dict__.get("_initialised"):
            return f"<{type(self).__name__}, not initialised>"
        values = ", ".join(f"{p.name}={getattr(self, 'get' + p.accessor)()!r}" for p in PARAMETERS)
        return f"LiFF({values})"


def _bind(args: tuple, kwargs: dict) -> dict:
    """create()'s arguments as keywords (TypeError for too many, unknown or repeated)."""
    try:
        bound = _SIGNATURE.bind(*args, **kwargs)
    except TypeError as error:
        names = ", ".join(p.name for p in PARAMETERS)
        raise TypeError(f"LiFF.create: {error}; expected at most {len(PARAMETERS)} arguments "
                        f"({names})") from None
    return dict(bound.arguments)


LiFF.__doc__ = (LiFF.__doc__ or "").format(parameters=_parameters_docstring().strip())
# (Signatures of the functions themselves: inspect drops the first, self or cls, when
# they are bound.)
LiFF.__init__.__signature__ = _SIGNATURE.replace(parameters=[  # type: ignore[attr-defined]
    inspect.Parameter("self", inspect.Parameter.POSITIONAL_ONLY), *_SIGNATURE.parameters.values()])
LiFF.create.__func__.__signature__ = _SIGNATURE.replace(parameters=[  # type: ignore[attr-defined]
    inspect.Parameter("cls", inspect.Parameter.POSITIONAL_ONLY), *_SIGNATURE.parameters.values()])
LiFF_create = LiFF.create
