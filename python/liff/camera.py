"""A calibrated light field camera: metric depth, 3-D position and size of LiFF features.

For a calibrated camera, a feature's slope gives its depth, hence an absolute 3-D
position and an absolute size (Dansereau et al., CVPR 2019, Sec. 6, Conclusion). The
model, in liff's slope convention (docs/CONVENTIONS.md: the HCI benchmark's disparity)::

    slope = focal_length * baseline * (1 / Z - 1 / focus_distance)

for a point at depth Z in front of the centre view. It holds for rectified views on a
regular grid with parallel optical axes whose principal points may be shifted so that
slope 0 lies at ``focus_distance`` (an HCI scene's shift-sensor cameras, a plenoptic
camera's sub-aperture views after the Light Field Toolbox's rectification, a camera
array). The derivations of :meth:`LightFieldCamera.from_hci` and
:meth:`LightFieldCamera.from_lftoolbox` are in docs/METRIC.md.
"""

from __future__ import annotations

import configparser
import math
import os
from dataclasses import dataclass
from typing import Optional, Sequence, Tuple, Union

import cv2
import numpy as np

from .keypoint_rows import keypoint_slopes

PathLike = Union[str, os.PathLike]
#: the parameters.cfg entries (section, key) that :meth:`LightFieldCamera.from_hci` reads
HCI_CAMERA_KEYS = (("intrinsics", "focal_length_mm"), ("intrinsics", "sensor_size_mm"),
                   ("intrinsics", "image_resolution_x_px"), ("intrinsics", "image_resolution_y_px"),
                   ("extrinsics", "baseline_mm"), ("extrinsics", "focus_distance_m"))


def _positive(name: str, value, allow_inf: bool = False) -> float:
    if isinstance(value, (str, bytes, bool, np.bool_)):  # float() would take "1000" and True
        raise ValueError(f"{name} = {value!r}; expected a number")
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {value!r}; expected a number") from None
    if math.isnan(value) or value <= 0 or (math.isinf(value) and not allow_inf):
        expected = "a positive number or inf" if allow_inf else "a positive finite number"
        raise ValueError(f"{name} = {value!r}; expected {expected}")
    return value


def read_hci_parameters(path: PathLike) -> Tuple[dict, str]:
    """(``{section: {key: text}}``, the file's path) of an HCI scene's parameters.cfg,
    given the scene folder or the file; ValueError naming the file if it is missing or
    unreadable."""
    path = os.fspath(path)
    cfg_path = os.path.join(path, "parameters.cfg") if os.path.isdir(path) else path
    if not os.path.isfile(cfg_path):
        raise ValueError(f"{cfg_path}: no such file; expected an HCI scene folder or its "
                         "parameters.cfg")
    cfg = configparser.ConfigParser(interpolation=None)
    try:
        with open(cfg_path, encoding="utf-8") as f:
            cfg.read_file(f)
    except (configparser.Error, UnicodeDecodeError) as error:
        raise ValueError(f"{cfg_path}: unreadable ({error}); expected an HCI parameters.cfg") from None
    return {s: dict(cfg[s]) for s in cfg.sections()}, cfg_path


def keypoint_geometry(keypoints: Sequence[cv2.KeyPoint]) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the camera model measures of LiFF keypoints: positions (N, 2), centre-view
    pixels; sizes (N,), pixels; slopes (N,), pixels per view step; all float64.

    Raises
    ------
    ValueError
        If an element is not a ``cv2.KeyPoint``, a position or size is not finite, or the
        keypoints carry no slope (every ``class_id`` -1, as ``cv2.SIFT``'s:
        :func:`liff.keypoint_slopes` with ``require``).
    """
    keypoints = list(keypoints)
    for k in keypoints:
        if not isinstance(k, cv2.KeyPoint):
            raise ValueError(f"keypoints hold a {type(k).__name__}; expected cv2.KeyPoint")
    points = np.array([k.pt for k in keypoints], np.float64).reshape(-1, 2)
    sizes = np.array([k.size for k in keypoints], np.float64)
    bad = ~(np.isfinite(points).all(axis=1) & np.isfinite(sizes))
    if bad.any():
        raise ValueError(f"{int(bad.sum())} keypoints (first: index {int(np.argmax(bad))}) with a "
                         "position or size that is not finite; expected finite pixel coordinates")
    return points, sizes, keypoint_slopes(keypoints, require=True)


@dataclass(frozen=True)
class LightFieldCamera:
    """A calibrated light field camera (rectified views on a regular grid).

    Parameters
    ----------
    focal_length : float
        Focal length of the centre view in pixels (square pixels), > 0.
    baseline : float
        Distance between neighbouring views in metres, > 0 (the same along rows and
        columns).
    principal_point : (float, float)
        (cx, cy) of the centre view in liff pixel coordinates (pixel centres at
        integers, docs/CONVENTIONS.md), finite.
    focus_distance : float, default inf
        Depth in metres whose slope is 0, > 0; ``inf`` for parallel cameras whose
        principal points are not shifted (slope = focal_length * baseline / Z).

    Raises
    ------
    ValueError
        If an argument is out of its range; the message names the range.

    Notes
    -----
    Depth and slope are related by (docs/METRIC.md)::

        slope = focal_length * baseline * (1 / Z - 1 / focus_distance)

    with the slope in pixels per view step and liff's sign (larger slopes are nearer).
    Coordinates are the centre view's OpenCV camera frame: x right, y down, z forward,
    in metres, origin at the centre view's centre of projection.
    """

    focal_length: float
    baseline: float
    principal_point: Tuple[float, float]
    focus_distance: float = math.inf

    def __post_init__(self):
        object.__setattr__(self, "focal_length", _positive("focal_length", self.focal_length))
        object.__setattr__(self, "baseline", _positive("baseline", self.baseline))
        object.__setattr__(self, "focus_distance",
                           _positive("focus_distance", self.focus_distance, allow_inf=True))
        try:
            cx, cy = (float(v) for v in self.principal_point)
        except (TypeError, ValueError):
            raise ValueError(f"principal_point = {self.principal_point!r}; expected two numbers "
                             "(cx, cy) in pixels") from None
        if not (math.isfinite(cx) and math.isfinite(cy)):
            raise ValueError(f"principal_point = {self.principal_point!r}; expected finite (cx, cy)")
        object.__setattr__(self, "principal_point", (cx, cy))

    # --- the model ---------------------------------------------------------------------

    @property
    def slope_scale(self) -> float:
        """``focal_length * baseline``: slope = slope_scale * (1/Z - 1/focus_distance),
        pixels per view step times metres."""
        return self.focal_length * self.baseline

    @property
    def slope_at_infinity(self) -> float:
        """The slope of points at infinite depth, ``-focal_length * baseline /
        focus_distance`` (0 for focus_distance = inf); slopes at or below it have no
        depth in front of the camera."""
        return -self.slope_scale / self.focus_distance

    def inverse_depth(self, slopes) -> np.ndarray:
        """1 / Z in 1/metres of each slope, shape (N,): ``slope / (f b) + 1 /
        focus_distance``. Zero at infinity, negative beyond it (no real point)."""
        slopes = np.asarray(slopes, np.float64).reshape(-1)
        return slopes / self.slope_scale + 1.0 / self.focus_distance

    def slopes(self, depths) -> np.ndarray:
        """Slope (pixels per view step) of points at depths Z (metres), shape (N,)."""
        depths = np.asarray(depths, np.float64).reshape(-1)
        return self.slope_scale * (1.0 / depths - 1.0 / self.focus_distance)

    def depth(self, slopes) -> np.ndarray:
        """Depth Z in metres of each slope.

        Parameters
        ----------
        slopes : array_like, shape (N,)
            Pixels per view step, liff's sign (:func:`liff.keypoint_slopes`).

        Returns
        -------
        ndarray of float64, shape (N,)
            ``Z = 1 / (slope / (focal_length * baseline) + 1 / focus_distance)``;
            NaN for slopes at or beyond infinity (``slope <= slope_at_infinity``), which
            no point in front of the camera has: there the model gives no depth.
        """
        inverse = self.inverse_depth(slopes)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(inverse > 0, 1.0 / inverse, np.nan)

    def points_3d(self, keypoints: Sequence[cv2.KeyPoint]) -> np.ndarray:
        """3-D positions of LiFF keypoints.

        Parameters
        ----------
        keypoints : sequence of cv2.KeyPoint, length N
            LiFF keypoints: centre-view pixels, slope in ``class_id``.

        Returns
        -------
        ndarray of float64, shape (N, 3)
            (X, Y, Z) in metres in the centre view's OpenCV camera frame (x right,
            y down, z forward): ``X = (x - cx) Z / f``, ``Y = (y - cy) Z / f``, Z from
            :meth:`depth`; rows of NaN where the slope is at or beyond infinity.

        Raises
        ------
        ValueError
            If the keypoints carry no slope (every ``class_id`` -1, as ``cv2.SIFT``'s).
        """
        points, _, slopes = keypoint_geometry(keypoints)
        return self.back_project(points, self.depth(slopes))

    def back_project(self, pixels, depths) -> np.ndarray:
        """3-D points (N, 3) at ``depths`` (N,) metres along the centre view's rays
        through ``pixels`` (N, 2): ``((x - cx) Z / f, (y - cy) Z / f, Z)``."""
        pixels = np.asarray(pixels, np.float64).reshape(-1, 2)
        z = np.asarray(depths, np.float64).reshape(-1)
        cx, cy = self.principal_point
        return np.column_stack([(pixels[:, 0] - cx) * z / self.focal_length,
                                (pixels[:, 1] - cy) * z / self.focal_length, z])

    def metric_size(self, keypoints: Sequence[cv2.KeyPoint]) -> np.ndarray:
        """Physical size of LiFF keypoints, shape (N,), metres.

        ``size * Z / focal_length``: the keypoint's diameter (``cv2.KeyPoint.size``, 2
        sigma, in pixels) at its depth. NaN where the slope is at or beyond infinity.
        Independent of the distance from which a feature is seen, which makes matching
        scale-sensitive (:func:`liff.matching.ratio_matches`). ValueError if the
        keypoints carry no slope (every ``class_id`` -1, as ``cv2.SIFT``'s).
        """
        _, sizes, slopes = keypoint_geometry(keypoints)
        return sizes * self.depth(slopes) / self.focal_length

    def matrix(self) -> np.ndarray:
        """The centre view's 3x3 calibration matrix K (OpenCV pixels), float64."""
        cx, cy = self.principal_point
        f = self.focal_length
        return np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]])

    # --- calibrations from elsewhere ---------------------------------------------------

    @classmethod
    def from_hci(cls, path: PathLike) -> "LightFieldCamera":
        """The camera of an HCI 4D light field benchmark scene (Honauer et al., ACCV 2016).

        Parameters
        ----------
        path : path
            A scene folder holding ``parameters.cfg``, or that file.

        Returns
        -------
        LightFieldCamera
            ``focal_length = focal_length_mm / sensor_size_mm * max(width, height)``
            pixels, ``baseline = baseline_mm / 1000``, ``focus_distance =
            focus_distance_m``, principal point at the image centre ((W - 1) / 2,
            (H - 1) / 2). This is the benchmark's published disparity-to-depth relation
            (its evaluation toolkit: depth_mm = beta * F / (disp * F * sensor_mm + beta),
            beta = baseline_mm * focal_mm * max(W, H), F = focus distance in mm)
            rewritten in pixels; see docs/METRIC.md.

        Raises
        ------
        ValueError
            If the file is missing or unreadable, or an entry is missing or out of range
            (the message names the file and the entry).
        """
        parameters, cfg_path = read_hci_parameters(path)
        return cls.from_hci_parameters(parameters, cfg_path)

    @classmethod
    def from_hci_parameters(cls, parameters: dict, source: str = "parameters.cfg") -> "LightFieldCamera":
        """:meth:`from_hci` on an already parsed parameters.cfg (``{section: {key: text}}``,
        as :func:`liff.io.read_hci` returns it); ``source`` names it in errors."""

        def entry(section: str, key: str, integer: bool = False) -> float:
            try:
                text = parameters[section][key]
            except (KeyError, TypeError):
                raise ValueError(f"{source}: [{section}] {key} missing; expected an HCI "
                                 "parameters.cfg with the camera intrinsics and extrinsics") from None
            try:
                value = int(text) if integer else float(text)
            except (TypeError, ValueError):
                raise ValueError(f"{source}: [{section}] {key} = {text!r}; expected a "
                                 f"{'whole ' if integer else ''}number") from None
            if not math.isfinite(value) or value <= 0:
                raise ValueError(f"{source}: [{section}] {key} = {text!r}; expected a positive "
                                 "finite number")
            return value

        focal_mm, sensor_mm, width, height, baseline_mm, focus_m = (
            entry(section, key, integer=key.endswith("_px")) for section, key in HCI_CAMERA_KEYS)
        return cls(focal_length=focal_mm / sensor_mm * max(width, height),
                   baseline=baseline_mm / 1000.0,
                   principal_point=((width - 1) / 2.0, (height - 1) / 2.0),
                   focus_distance=focus_m)

    @classmethod
    def from_lftoolbox(cls, H, views: Optional[Tuple[int, int]] = None,
                       rtol: float = 1e-3) -> "LightFieldCamera":
        """The camera of a light field rectified by the Light Field Toolbox (Dansereau,
        Pizarro and Williams, CVPR 2013).

        Parameters
        ----------
        H : array_like, shape (5, 5)
            The toolbox's intrinsic matrix of the rectified light field
            (``RectCamIntrinsicsH``): it maps 1-based sample indices ``[i; j; k; l; 1]``
            of ``LF(j, i, l, k)`` (view column, view row, pixel column, pixel row) to the
            ray ``[s; t; u; v; 1]`` that crosses the plane z = 0 at (s, t) metres with
            direction (u, v, 1) (the relative two-plane parameterisation), in the form
            ``[[H11, 0, H13, 0, H15], [0, H22, 0, H24, H25], [H31, 0, H33, 0, H35],
            [0, H42, 0, H44, H45], [0, 0, 0, 0, 1]]``.
        views : (T, S), optional
            The light field's view grid, to locate the centre view. Default: the view
            whose central pixel H maps to the ray s = t = u = v = 0, where the toolbox's
            ``LFRecenterIntrinsics`` puts the centre sample.
        rtol : float, default 1e-3
            How far the horizontal and vertical parts of H may disagree (relative)
            before H is refused: the model has square pixels and one baseline.

        Returns
        -------
        LightFieldCamera
            With (docs/METRIC.md) ``focal_length = 1 / H33``, ``baseline = H11 - H31 *
            H13 / H33``, ``focus_distance = -baseline / H31`` (inf for H31 = 0), the
            principal point from u = 0 in the centre view; depths are measured from the
            views' centres of projection, at z = -H13 / H33 in the toolbox's frame.

        Raises
        ------
        ValueError
            For a matrix of another shape, non-finite entries, entries outside that
            form, a mirrored or degenerate geometry (focal length or baseline not
            positive, focus behind the camera), or rows and columns that disagree.
        """
        H = np.asarray(H, dtype=np.float64)
        if H.shape != (5, 5):
            raise ValueError(f"H has shape {H.shape}; expected the Light Field Toolbox's 5x5 "
                             "intrinsic matrix")
        if not np.isfinite(H).all():
            raise ValueError("H has non-finite entries; expected a finite 5x5 matrix")
        form = np.zeros((5, 5), bool)
        form[[0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4], [0, 2, 4, 1, 3, 4, 0, 2, 4, 1, 3, 4, 4]] = True
        scale = np.abs(H[:4, :4]).max()
        if np.abs(H[~form]).max() > 1e-9 * scale or abs(H[4, 4] - 1) > 1e-9:
            raise ValueError("H mixes horizontal and vertical coordinates or its last row is not "
                             "[0 0 0 0 1]; expected [[H11 0 H13 0 H15] [0 H22 0 H24 H25] [H31 0 "
                             "H33 0 H35] [0 H42 0 H44 H45] [0 0 0 0 1]] (a rectified light field)")
        if not 0 < rtol < 1:
            raise ValueError(f"rtol = {rtol}; expected a value in (0, 1)")

        if views is not None:
            try:
                T, S = (int(v) for v in views)
            except (TypeError, ValueError):
                raise ValueError(f"views = {views!r}; expected (T, S)") from None
            if T < 1 or S < 1:
                raise ValueError(f"views = {views!r}; expected positive (T, S)")

        def axis(a: int, b: int, count: Optional[int]):
            """focal, baseline, 1/focus, principal point of one axis: rows a (position)
            and b = a + 2 (direction) of H, view column a, pixel column b."""
            h11, h13, h15 = H[a, a], H[a, b], H[a, 4]
            h31, h33, h35 = H[b, a], H[b, b], H[b, 4]
            if not h33 > 0:
                raise ValueError(f"H[{b + 1},{b + 1}] = {h33}; expected > 0 (1 / focal length "
                                 "in pixels; a negative value is a mirrored image)")
            focal = 1.0 / h33
            baseline = h11 - h31 * h13 / h33
            if not baseline > 0:
                raise ValueError(f"H gives a baseline of {baseline} m between views along axis "
                                 f"{'s' if a == 0 else 't'}; expected > 0 (views ordered left "
                                 "to right, top to bottom)")
            if count is None:  # the centre sample maps to s = u = 0 (LFRecenterIntrinsics)
                centre_view, centre_pixel = np.linalg.solve([[h11, h13], [h31, h33]], [-h15, -h35])
            else:
                centre_view = (count - 1) / 2.0 + 1.0
                centre_pixel = -(h31 * centre_view + h35) / h33
            return focal, baseline, -h31 / baseline, centre_pixel - 1.0  # 0-based pixels

        fx, bx, ifx, cx = axis(0, 2, None if views is None else S)
        fy, by, ify, cy = axis(1, 3, None if views is None else T)
        # slope at infinity, pixels per view step: compared relative to 1 px when near 0
        for name, x, y, floor in (("focal length", fx, fy, 0.0), ("baseline", bx, by, 0.0),
                                  ("slope at infinity", fx * bx * ifx, fy * by * ify, 1.0)):
            if abs(x - y) > rtol * max(abs(x), abs(y), floor):
                raise ValueError(f"H's {name} differs between s and t ({x:.6g} vs {y:.6g}); "
                                 "expected square pixels and one baseline, as the toolbox's "
                                 "default rectification gives")
        inverse_focus = (ifx + ify) / 2
        if inverse_focus < 0:
            raise ValueError(f"H puts slope 0 at depth {1 / inverse_focus:.6g} m, behind the "
                             "camera; expected H31 <= 0")
        return cls(focal_length=(fx + fy) / 2, baseline=(bx + by) / 2, principal_point=(cx, cy),
                   focus_distance=math.inf if inverse_focus == 0 else 1.0 / inverse_focus)
