"""The Python face of the detector: cv2 types in, cv2 types out."""

from __future__ import annotations

import os
from typing import Optional, Sequence, Tuple, Union

import cv2
import numpy as np

from . import _core

SLOPE_SCALE = _core.SLOPE_SCALE

KeyPoints = Tuple[cv2.KeyPoint, ...]


def _as_light_field(lf) -> np.ndarray:
    """C-contiguous, native-byte-order view (or copy) of ``lf``; never modifies it."""
    if not isinstance(lf, np.ndarray):
        if hasattr(lf, "get") and callable(lf.get):  # cv2.UMat
            lf = lf.get()
        lf = np.asarray(lf)
    if lf.dtype.kind == "b":
        raise ValueError("light field dtype is bool; expected uint8, uint16, float32 or float64")
    if not lf.dtype.isnative:
        lf = lf.astype(lf.dtype.newbyteorder("="))
    # (np.ascontiguousarray would turn a 0-d array into shape (1,).)
    return lf if lf.flags.c_contiguous else np.ascontiguousarray(lf)


def _as_mask(mask) -> Optional[np.ndarray]:
    if mask is None:
        return None
    mask = np.asarray(mask)
    if mask.dtype == np.bool_:
        mask = mask.astype(np.uint8)
    return mask if mask.flags.c_contiguous else np.ascontiguousarray(mask)


def _keypoints_to_rows(keypoints) -> np.ndarray:
    rows = []
    for i, k in enumerate(keypoints):
        if not isinstance(k, cv2.KeyPoint):
            raise TypeError(f"keypoints[{i}] is {type(k).__name__}; expected cv2.KeyPoint")
        rows.append((k.pt[0], k.pt[1], k.size, k.angle, k.response, k.octave, k.class_id))
    return np.asarray(rows, dtype=np.float64).reshape(-1, 7)


def _rows_to_keypoints(rows: np.ndarray) -> KeyPoints:
    return tuple(
        cv2.KeyPoint(x, y, size, angle, response, int(octave), int(class_id))
        for x, y, size, angle, response, octave, class_id in rows.tolist()
    )


def _copy_scalars(node: "cv2.FileNode", fs: "cv2.FileStorage") -> None:
    """Writes the string, int and real entries of the map ``node`` into ``fs``."""
    for key in node.keys():
        child = node.getNode(key)
        if child.isString():
            fs.write(key, child.string())
        elif child.isInt():
            fs.write(key, int(child.real()))
        elif child.isReal():
            fs.write(key, child.real())


def keypoint_slopes(keypoints: Sequence[cv2.KeyPoint]) -> np.ndarray:
    """Slopes of LiFF keypoints.

    Parameters
    ----------
    keypoints : sequence of cv2.KeyPoint
        Keypoints from :class:`LiFF`; the slope is stored in ``class_id`` as
        ``round(slope * SLOPE_SCALE)`` with ``SLOPE_SCALE = 65536``.

    Returns
    -------
    slopes : ndarray of float64, shape (N,)
        Pixels per view step: a point at (x, y) in the centre view appears at
        ``(x - slope*(s - s_c), y - slope*(t - t_c))`` in view (t, s).
    """
    return np.fromiter((k.class_id for k in keypoints), dtype=np.float64) / SLOPE_SCALE


class LiFF(_core.LiFF):
    """Light field features in scale and depth, a drop-in for ``cv2.SIFT``.

    Parameters
    ----------
    nfeatures : int, default 0
        Keep the ``nfeatures`` strongest features by response (0 keeps all).
    nOctaveLayers : int, default 3
        DoG layers per octave, as ``cv2.SIFT``.
    contrastThreshold : float, default 0.04
        As ``cv2.SIFT``: a feature needs DoG contrast >= contrastThreshold / nOctaveLayers
        on intensities in [0, 1].
    edgeThreshold : float, default 10
        Maximum ratio of principal curvatures, as ``cv2.SIFT``.
    sigma : float, default 1.6
        Gaussian sigma of the base octave, as ``cv2.SIFT``.
    firstSlope, lastSlope : float, default -1, 1
        Range of slopes (pixels per view step) of the focal stack.
    numSlopes : int, default 0
        Number of slopes in ``linspace(firstSlope, lastSlope, numSlopes)``; 0 picks the
        smallest odd number >= max(T, S).
    descriptorType : int, default cv2.CV_32F
        ``cv2.CV_32F`` or ``cv2.CV_8U``; values are SIFT's integers in [0, 255] either way.
    rootSift : bool, default False
        RootSIFT normalisation (L1, then square root), which the paper found better for SfM.

    Notes
    -----
    Light fields are numpy arrays of shape ``(T, S, V, U)`` or ``(T, S, V, U, C)``
    (view row, view column, pixel row, pixel column, channel), C = 1 (grey), 2 (grey +
    alpha), 3 (BGR, as OpenCV) or 4 (BGRA), dtype uint8 (/255), uint16 (/65535), float32
    or float64 (taken as given, nominally in [0, 1]). An alpha channel is a per-sample
    validity weight ``a >= 0`` (e.g. a Lytro lenslet image's vignetting mask): the
    focal stack becomes ``sum(a L) / sum(a)``. A 2-D image ``(V, U)`` or ``(V, U, C)``
    is a 1x1 light field, for which LiFF behaves as SIFT.
    """

    @classmethod
    def create(
        cls,
        nfeatures: int = 0,
        nOctaveLayers: int = 3,
        contrastThreshold: float = 0.04,
        edgeThreshold: float = 10,
        sigma: float = 1.6,
        firstSlope: float = -1,
        lastSlope: float = 1,
        numSlopes: int = 0,
        descriptorType: int = cv2.CV_32F,
        rootSift: bool = False,
    ) -> "LiFF":
        """Creates a detector (keywords as the class). Raises ValueError if out of range."""
        return cls(
            nfeatures=nfeatures,
            nOctaveLayers=nOctaveLayers,
            contrastThreshold=contrastThreshold,
            edgeThreshold=edgeThreshold,
            sigma=sigma,
            firstSlope=firstSlope,
            lastSlope=lastSlope,
            numSlopes=numSlopes,
            descriptorType=descriptorType,
            rootSift=rootSift,
        )

    def detect(self, lf, mask=None) -> KeyPoints:
        """Detects keypoints.

        Parameters
        ----------
        lf : array_like, shape (T, S, V, U[, C]) or (V, U[, C])
            The light field (see the class notes).
        mask : ndarray of uint8 or bool, shape (V, U), optional
            Keep keypoints whose centre-view pixel is non-zero.

        Returns
        -------
        keypoints : tuple of cv2.KeyPoint
            ``pt`` in centre-view pixels, ``size`` a diameter, ``angle`` in degrees,
            ``response`` the |DoG| contrast, ``octave`` packed as cv2.SIFT, slope in
            ``class_id`` (see :func:`keypoint_slopes`).
        """
        rows, _ = self._run(_as_light_field(lf), _as_mask(mask), None, False)
        return _rows_to_keypoints(rows)

    def compute(self, lf, keypoints, descriptors=None) -> Tuple[KeyPoints, Optional[np.ndarray]]:
        """Describes the given keypoints, each on the focal slice nearest its slope.

        Keypoints whose packed octave/layer the light field's pyramid lacks are removed
        (cv2.Feature2D behaviour), so the returned tuple may be shorter.

        Returns
        -------
        keypoints : tuple of cv2.KeyPoint
        descriptors : ndarray, shape (N, 128), float32 (or uint8), or None if N == 0
        """
        rows = _keypoints_to_rows(keypoints)
        rows, desc = self._run(_as_light_field(lf), None, rows, True)
        return _rows_to_keypoints(rows), (desc if len(rows) else None)

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
        descriptors : ndarray, shape (N, 128), float32 (or uint8), or None if N == 0
            Exactly as ``cv2.SIFT.detectAndCompute``.
        """
        if useProvidedKeypoints:
            raise ValueError("useProvidedKeypoints=True: call compute(lf, keypoints) instead")
        rows, desc = self._run(_as_light_field(lf), _as_mask(mask), None, True)
        return _rows_to_keypoints(rows), (desc if len(rows) else None)

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
        detector is unchanged then.
        """
        if isinstance(source, (str, os.PathLike)):
            path = os.fspath(source)
            if not os.path.isfile(path):
                raise ValueError(f"cannot read LiFF parameters: no file '{path}'")
            self._read_file(path)
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
        return (
            f"LiFF(nfeatures={self.getNFeatures()}, nOctaveLayers={self.getNOctaveLayers()}, "
            f"contrastThreshold={self.getContrastThreshold()}, "
            f"edgeThreshold={self.getEdgeThreshold()}, sigma={self.getSigma()}, "
            f"firstSlope={self.getFirstSlope()}, lastSlope={self.getLastSlope()}, "
            f"numSlopes={self.getNumSlopes()}, descriptorType={self.getDescriptorType()}, "
            f"rootSift={self.getRootSift()})"
        )


LiFF_create = LiFF.create
