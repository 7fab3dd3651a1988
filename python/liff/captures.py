"""Synthetic multi-view light-field captures of a 3-D scene, for structure from motion.

A scene is a set of textured planar rectangles (:class:`Patch`): a back wall, a floor,
boxes, free-standing panels and, optionally, a fence of thin bars in front. A capture is
a camera array of T x S views (baseline ``b`` between neighbours, parallel axes, the same
intrinsics) placed at several poses along an arc around the scene; every pose yields one
light field ``L[t, s, v, u]`` (docs/CONVENTIONS.md), rendered by casting rays against the
rectangles (nearest hit wins) with bilinear texture sampling and supersampling.

Geometry (OpenCV/COLMAP camera frame: x right, y down, z forward). A pose is the
world-to-camera transform of the centre view, ``x_cam = R @ X + t``. View (t, s) sits at
``C + R.T @ [b*(s - s_c), b*(t - t_c), 0]``, so a point at depth Z appears at

    (x - slope*(s - s_c),  y - slope*(t - t_c)),   slope = f*b*(1/Z - 1/focus_depth)

in view (t, s), where (x, y) is its centre-view position: liff's slope convention. With
``focus_depth = inf`` (a plain camera array) slope = f*b/Z; a finite ``focus_depth``
shifts each view's principal point so that slope 0 lies at that depth, as the
sub-aperture views of a plenoptic camera (which is what the paper's Lytro gave), and
nearer points keep the larger slopes.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import List, Optional, Sequence, Tuple

import cv2
import numpy as np


@dataclass(frozen=True)
class Patch:
    """A textured rectangle in world coordinates.

    Attributes
    ----------
    centre : ndarray, shape (3,)
    axis_u, axis_v : ndarray, shape (3,)
        Half-extent vectors, orthogonal: the rectangle is ``centre + a*axis_u + b*axis_v``
        for a, b in [-1, 1]. ``axis_u`` runs along the texture's columns, ``axis_v`` along
        its rows.
    texture : ndarray of float32, shape (H, W)
        Intensities, nominally in [0, 1].
    """

    centre: np.ndarray
    axis_u: np.ndarray
    axis_v: np.ndarray
    texture: np.ndarray


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of every view, in OpenCV's pixel convention (integer
    coordinates at pixel centres; COLMAP's principal point is ``cx + 0.5, cy + 0.5``).

    Attributes
    ----------
    focal : float
        Focal length in pixels (square pixels).
    cx, cy : float
        Principal point of a view on the array's axis (for focus_depth = inf, every view).
    width, height : int
        Image size U x V in pixels.
    """

    focal: float
    cx: float
    cy: float
    width: int
    height: int

    def matrix(self) -> np.ndarray:
        """The 3x3 calibration matrix K (float64)."""
        return np.array([[self.focal, 0, self.cx], [0, self.focal, self.cy], [0, 0, 1.0]])


@dataclass(frozen=True)
class Pose:
    """World-to-camera transform of a capture's centre view: ``x_cam = rotation @ X + translation``."""

    rotation: np.ndarray
    translation: np.ndarray

    @property
    def centre(self) -> np.ndarray:
        """Camera centre in world coordinates, shape (3,)."""
        return -self.rotation.T @ self.translation


@dataclass
class Capture:
    """Light fields of one scene from several poses.

    Attributes
    ----------
    light_fields : list of ndarray of float32, shape (T, S, V, U)
        One per pose; intensities nominally in [0, 1] (noise is not clipped).
    poses : list of Pose
        Ground truth, centre view of each light field.
    intrinsics : Intrinsics
    baseline : float
        Distance between neighbouring views, world units.
    focus_depth : float
        Depth of slope 0 (``inf``: a plain camera array).
    patches : tuple of Patch
        The scene.
    """

    light_fields: List[np.ndarray]
    poses: List[Pose]
    intrinsics: Intrinsics
    baseline: float
    focus_depth: float = np.inf
    patches: Tuple[Patch, ...] = field(default=(), repr=False)

    def slope_at_depth(self, depth) -> np.ndarray:
        """Slope (pixels per view step, liff's sign) of points at ``depth`` (world units)."""
        return self.intrinsics.focal * self.baseline * (1.0 / np.asarray(depth) - 1.0 / self.focus_depth)

    def depth_map(self, index: int) -> np.ndarray:
        """Ground-truth depth of light field ``index``'s centre view at its pixel centres
        (world units along the optical axis, ``inf`` where no patch is hit), (V, U)
        float32: the nearest patch along each pixel's central ray."""
        if not isinstance(index, (int, np.integer)) or not 0 <= index < len(self.poses):
            raise ValueError(f"index = {index!r}; expected an integer in [0, {len(self.poses)})")
        k, pose = self.intrinsics, self.poses[index]
        x = (np.arange(k.width) - k.cx) / k.focal
        y = (np.arange(k.height) - k.cy) / k.focal
        return _cast(self.patches, pose.rotation, pose.centre, x, y, 0.0)[1]

    def slope_range(self) -> Tuple[float, float]:
        """The smallest and largest true slope (pixels per view step) in the centre views
        of all poses, from :meth:`depth_map`: the range a detector must search."""
        per_pose = [self.slope_at_depth(d[np.isfinite(d)])
                    for d in map(self.depth_map, range(len(self.poses)))]
        slopes = np.concatenate([s.ravel() for s in per_pose]) if per_pose else np.zeros(0)
        if slopes.size == 0:
            raise ValueError("no patch is seen from any pose; expected a capture of a scene")
        return float(slopes.min()), float(slopes.max())

    def centre_views(self) -> List[np.ndarray]:
        """The centre view ``L[T // 2, S // 2]`` of every light field, (V, U) float32."""
        return [lf[lf.shape[0] // 2, lf.shape[1] // 2] for lf in self.light_fields]


# --- textures and scenes ---------------------------------------------------------------

def structured_texture(rng: np.random.Generator, height: int, width: int) -> np.ndarray:
    """A texture with structure at several scales, for SIFT to find and match.

    Smoothed noise at sigmas 1.5 to 12 texels, plus random Gaussian blobs, plus
    piecewise-constant polygons and lines (edges and corners). Returns float32 (H, W)
    with mean about 0.5, clipped to [0.02, 0.98].
    """
    tex = np.zeros((height, width), np.float32)
    for sigma, weight in ((1.5, 0.5), (4.0, 0.8), (12.0, 1.0)):
        layer = cv2.GaussianBlur(rng.standard_normal((height, width)).astype(np.float32), (0, 0), sigma)
        tex += weight * layer / (layer.std() + 1e-12)
    tex *= 0.06
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float32)
    area = height * width
    for _ in range(area // 2500):  # blobs
        x, y, r = rng.uniform(0, width), rng.uniform(0, height), rng.uniform(2.5, 10.0)
        amplitude = rng.choice((-1, 1)) * rng.uniform(0.15, 0.3)
        tex += amplitude * np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / (2 * r * r))
    shapes = np.zeros((height, width), np.float32)
    for _ in range(area // 4000):  # polygons: edges and corners
        centre = rng.uniform((0, 0), (width, height))
        n = int(rng.integers(3, 6))
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))
        radii = rng.uniform(5, 25, n)
        pts = centre + np.stack([np.cos(angles), np.sin(angles)], 1) * radii[:, None]
        cv2.fillPoly(shapes, [np.round(pts * 4).astype(np.int32)], float(rng.uniform(-0.25, 0.25)),
                     lineType=cv2.LINE_AA, shift=2)
    for _ in range(area // 8000):  # lines
        p, q = rng.uniform((0, 0), (width, height), (2, 2))
        cv2.line(shapes, tuple(int(v) for v in p * 4), tuple(int(v) for v in q * 4),
                 float(rng.uniform(-0.3, 0.3)), int(rng.integers(1, 3)), cv2.LINE_AA, shift=2)
    tex += shapes
    return np.clip(tex + 0.5, 0.02, 0.98).astype(np.float32)


def _rect(centre, axis_u, axis_v, texture) -> Patch:
    return Patch(np.asarray(centre, float), np.asarray(axis_u, float), np.asarray(axis_v, float),
                 np.ascontiguousarray(texture, np.float32))


def _box(rng, centre, half_size, texels_per_unit: float) -> List[Patch]:
    """The six faces of an axis-aligned box, each with its own texture."""
    c, (hx, hy, hz) = np.asarray(centre, float), half_size
    faces = []
    for offset, au, av in (((0, 0, -hz), (hx, 0, 0), (0, hy, 0)), ((0, 0, hz), (-hx, 0, 0), (0, hy, 0)),
                           ((-hx, 0, 0), (0, 0, -hz), (0, hy, 0)), ((hx, 0, 0), (0, 0, hz), (0, hy, 0)),
                           ((0, -hy, 0), (hx, 0, 0), (0, 0, hz)), ((0, hy, 0), (hx, 0, 0), (0, 0, -hz))):
        w = max(16, int(2 * np.linalg.norm(au) * texels_per_unit))
        h = max(16, int(2 * np.linalg.norm(av) * texels_per_unit))
        faces.append(_rect(c + offset, au, av, structured_texture(rng, h, w)))
    return faces


def box_scene(seed: int = 0, occluders: bool = False, texels_per_unit: float = 60.0) -> Tuple[Patch, ...]:
    """A random tabletop-like scene around the world origin.

    A back wall (12 x 7) at z = +2.5, a floor (12 x 4.8) at y = +1.4 (y points down),
    three boxes standing on the floor and two free-standing panels between z = -1.5 and
    +1.5, all textured by :func:`structured_texture`. With ``occluders``, a fence of thin
    dark bars (vertical posts and a few slanted branches, 0.05-0.09 units wide, covering
    about a fifth of a view) stands at z = -2.4, in front of everything, for cameras
    looking along +z from z of about -6.
    """
    rng = np.random.default_rng(seed)

    def tex(width, height):  # a texture for a rectangle of this size in world units
        return structured_texture(rng, int(height * texels_per_unit), int(width * texels_per_unit))

    patches = [_rect((0, -0.8, 2.5), (6.0, 0, 0), (0, 3.5, 0), tex(12.0, 7.0)),  # back wall
               _rect((0, 1.4, 0.3), (6.0, 0, 0), (0, 0, 2.4), tex(12.0, 4.8))]  # floor
    for _ in range(3):
        half = rng.uniform(0.3, 0.6, 3)
        centre = (rng.uniform(-2.0, 2.0), 1.4 - half[1], rng.uniform(-1.5, 1.5))
        patches += _box(rng, centre, half, texels_per_unit)
    for _ in range(2):  # panels facing the camera, turned about y by up to 30 degrees
        angle = np.radians(rng.uniform(-30, 30))
        w, h = rng.uniform(0.5, 0.9), rng.uniform(0.5, 0.9)
        centre = (rng.uniform(-2.2, 2.2), rng.uniform(-1.2, 0.2), rng.uniform(-1.2, 1.2))
        patches.append(_rect(centre, (w * np.cos(angle), 0, w * np.sin(angle)), (0, h, 0), tex(2 * w, 2 * h)))
    if occluders:
        patches += _fence(rng)
    return tuple(patches)


def _fence(rng: np.random.Generator, z: float = -2.4) -> List[Patch]:
    """Thin dark bars at depth ``z``: vertical posts about 0.55 apart and slanted branches."""
    bars = []
    bark = lambda n: np.clip(0.15 + 0.04 * rng.standard_normal((n, 4)), 0, 1)  # noqa: E731
    for x in np.arange(-3.0, 3.01, 0.55) + rng.uniform(-0.1, 0.1):
        half_width = rng.uniform(0.025, 0.045)
        bars.append(_rect((x, -0.3, z), (half_width, 0, 0), (0, 3.0, 0), bark(64)))
    for _ in range(5):
        angle = rng.uniform(0.3, 1.2) * rng.choice((-1, 1))
        length, half_width = rng.uniform(1.0, 2.0), rng.uniform(0.02, 0.035)
        along = np.array([np.sin(angle), np.cos(angle), 0.0])
        across = np.array([np.cos(angle), -np.sin(angle), 0.0])
        centre = (rng.uniform(-2.5, 2.5), rng.uniform(-1.5, 0.8), z - rng.uniform(0.0, 0.2))
        bars.append(_rect(centre, across * half_width, along * length, bark(64)))
    return bars


# --- cameras ---------------------------------------------------------------------------

def look_at(centre, target, up=(0.0, -1.0, 0.0)) -> Pose:
    """The pose of a camera at ``centre`` looking at ``target`` (y down in the image)."""
    centre, target = np.asarray(centre, float), np.asarray(target, float)
    z = target - centre
    z /= np.linalg.norm(z)
    x = np.cross(-np.asarray(up, float), z)  # -up is the image's y axis
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    rotation = np.stack([x, y, z])
    return Pose(rotation, -rotation @ centre)


def arc_poses(n: int, distance: float = 6.0, span_degrees: float = 40.0, seed: int = 0) -> List[Pose]:
    """``n`` poses on a horizontal arc of radius ``distance`` about the world origin,
    spanning ``span_degrees``, each looking at a point jittered about the origin and at
    a jittered height, so consecutive poses differ in position and rotation."""
    rng = np.random.default_rng(seed)
    poses = []
    for angle in np.radians(np.linspace(-span_degrees / 2, span_degrees / 2, n)):
        centre = (distance * np.sin(angle), rng.uniform(-0.6, 0.1), -distance * np.cos(angle))
        poses.append(look_at(centre, rng.uniform((-0.3, -0.2, -0.3), (0.3, 0.2, 0.3))))
    return poses


# --- rendering -------------------------------------------------------------------------

def render_light_field(
    patches: Sequence[Patch],
    pose: Pose,
    intrinsics: Intrinsics,
    views: Tuple[int, int] = (7, 7),
    baseline: float = 0.03,
    focus_depth: float = np.inf,
    supersample: int = 2,
    background: float = 0.5,
) -> np.ndarray:
    """Renders one light field of shape (T, S, V, U), float32.

    Rays leave each view's centre through ``supersample``^2 points per pixel (a regular
    grid inside the pixel), hit the nearest patch, take its texture bilinearly, and are
    averaged per pixel. Rays that hit nothing see ``background``.
    """
    T, S = views
    V, U, n = intrinsics.height, intrinsics.width, supersample
    inv_focus = 0.0 if np.isinf(focus_depth) else 1.0 / focus_depth
    lf = np.empty((T, S, V, U), np.float32)
    for t in range(T):
        for s in range(S):
            offset = np.array([baseline * (s - (S - 1) / 2), baseline * (t - (T - 1) / 2), 0.0])
            # Shifting the principal point by f*offset/focus_depth keeps slope 0 there.
            cx = intrinsics.cx + intrinsics.focal * offset[0] * inv_focus
            cy = intrinsics.cy + intrinsics.focal * offset[1] * inv_focus
            # Camera-frame directions (x, y, 1) of the sub-pixel samples, by column and row.
            samples = (np.arange(n) + 0.5) / n - 0.5
            x = ((np.arange(U)[:, None] + samples).ravel() - cx) / intrinsics.focal
            y = ((np.arange(V)[:, None] + samples).ravel() - cy) / intrinsics.focal
            centre = pose.centre + pose.rotation.T @ offset
            image = _cast(patches, pose.rotation, centre, x, y, background)[0]
            lf[t, s] = image.reshape(V, n, U, n).mean(axis=(1, 3))
    return lf


def _cast(patches: Sequence[Patch], rotation: np.ndarray, centre: np.ndarray,
          x: np.ndarray, y: np.ndarray, background: float) -> Tuple[np.ndarray, np.ndarray]:
    """Intensity and depth along the rays (x[j], y[i], 1) of a camera (world-to-camera
    rotation, centre in world), nearest patch first; each shape (len(y), len(x)),
    float32 (depth ``inf`` where no patch is hit)."""
    shape = (len(y), len(x))
    depth = np.full(shape, np.inf, np.float32)
    which = np.full(shape, -1, np.int32)  # nearest patch so far
    tex_col, tex_row = np.zeros(shape, np.float32), np.zeros(shape, np.float32)
    x, y = x.astype(np.float32), y.astype(np.float32)
    for i, p in enumerate(patches):
        c = rotation @ (p.centre - centre)  # everything in the camera frame
        au, av = rotation @ p.axis_u, rotation @ p.axis_v
        normal = np.cross(au, av)
        rows, cols = _footprint(c, au, av, x, y)
        if rows.stop <= rows.start or cols.stop <= cols.start:
            continue
        xs, ys = x[None, cols], y[rows, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.float32(c @ normal) / (xs * normal[0] + ys * normal[1] + np.float32(normal[2]))
        # Patch coordinates of the hit z*(x, y, 1), in [-1, 1] inside the rectangle.
        a = (z * (xs * au[0] + ys * au[1] + np.float32(au[2])) - np.float32(c @ au)) / np.float32(au @ au)
        b = (z * (xs * av[0] + ys * av[1] + np.float32(av[2])) - np.float32(c @ av)) / np.float32(av @ av)
        hit = (z > 1e-6) & (z < depth[rows, cols]) & (np.abs(a) <= 1) & (np.abs(b) <= 1)
        h, w = p.texture.shape
        depth[rows, cols][hit] = z[hit]
        which[rows, cols][hit] = i
        tex_col[rows, cols][hit] = (a[hit] + 1) * (w / 2) - 0.5
        tex_row[rows, cols][hit] = (b[hit] + 1) * (h / 2) - 0.5
    out = np.full(shape, background, np.float32)
    for i in np.unique(which[which >= 0]):
        sel = which == i
        out[sel] = _sample(patches[i].texture, tex_col[sel], tex_row[sel])
    return out, depth


def _sample(texture: np.ndarray, cols: np.ndarray, rows: np.ndarray, width: int = 1024) -> np.ndarray:
    """Bilinear samples of ``texture`` at (cols, rows), clamped at the border (cv2.remap,
    whose maps must be 2-D with fewer than 32767 rows: folded into rows of ``width``)."""
    n = len(cols)
    pad = -n % width
    maps = [np.pad(m, (0, pad)).reshape(-1, width) for m in (cols, rows)]
    return cv2.remap(texture, maps[0], maps[1], cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE).ravel()[:n]


def _footprint(c, au, av, x, y) -> Tuple[slice, slice]:
    """Rows and columns of the ray grid that can hit the rectangle (camera frame): the
    bounding box of its projected corners, or everything if a corner is behind the camera."""
    corners = np.array([c + i * au + j * av for i in (-1, 1) for j in (-1, 1)])
    if (corners[:, 2] <= 1e-9).any():
        return slice(0, len(y)), slice(0, len(x))
    px, py = corners[:, 0] / corners[:, 2], corners[:, 1] / corners[:, 2]
    # x and y are sorted, so searchsorted gives the index range inside the box.
    cols = slice(np.searchsorted(x, px.min()), np.searchsorted(x, px.max(), side="right"))
    rows = slice(np.searchsorted(y, py.min()), np.searchsorted(y, py.max(), side="right"))
    return rows, cols


# --- captures --------------------------------------------------------------------------

def make_capture(
    seed: int = 0,
    n_poses: int = 5,
    views: Tuple[int, int] = (7, 7),
    size: Tuple[int, int] = (240, 320),
    focal: float = 300.0,
    slope_range: Tuple[float, float] = (-1.0, 1.0),
    occluders: bool = False,
    supersample: int = 2,
    span_degrees: float = 40.0,
    patches: Optional[Sequence[Patch]] = None,
    poses: Optional[Sequence[Pose]] = None,
) -> Capture:
    """Renders a :func:`box_scene` from :func:`arc_poses` (or the given ones).

    Parameters
    ----------
    seed : int
        Seeds the scene and the trajectory; the same seed gives the same capture.
    n_poses : int
        Light fields to render.
    views : (T, S)
    size : (V, U)
        Pixels of each view.
    focal : float
        Focal length in pixels.
    slope_range : (float, float)
        Slopes (pixels per view step) of the far back wall and of a point 3.6 units from
        the camera (about the nearest box or the fence, for cameras 6 units from the
        origin): sets the baseline and the focus depth. The default spans liff's default
        [-1, 1], as the paper's Lytro sub-aperture views did.
    occluders : bool
        Add the fence (see :func:`box_scene`).
    supersample : int
        Rays per pixel along each axis.

    Returns
    -------
    Capture
    """
    if n_poses < 1 or min(views) < 1 or min(size) < 8 or supersample < 1:
        raise ValueError(f"n_poses = {n_poses}, views = {views}, size = {size}, supersample = "
                         f"{supersample}; expected n_poses, views, supersample >= 1 and size >= 8")
    far, near = 8.7, 3.6  # depths of the wall and of the nearest objects from z = -6
    lo, hi = slope_range
    if not hi > lo:
        raise ValueError(f"slope_range = {slope_range}; expected (far slope, near slope) with near > far")
    # Solve slope = f*b*(1/Z - 1/focus) at Z = far -> lo and Z = near -> hi.
    fb = (hi - lo) / (1 / near - 1 / far)
    inv_focus = 1 / near - hi / fb
    focus_depth = np.inf if abs(inv_focus) < 1e-12 else 1 / inv_focus
    V, U = size
    intrinsics = Intrinsics(float(focal), (U - 1) / 2, (V - 1) / 2, U, V)
    patches = tuple(patches) if patches is not None else box_scene(seed, occluders)
    poses = list(poses) if poses is not None else arc_poses(n_poses, span_degrees=span_degrees, seed=seed)
    baseline = fb / focal
    lfs = [render_light_field(patches, p, intrinsics, views, baseline, focus_depth, supersample)
           for p in poses]
    return Capture(lfs, poses, intrinsics, baseline, focus_depth, patches)


def degrade(capture: Capture, contrast: float = 1.0, noise_variance: float = 0.0,
            mean: float = 0.5, seed: int = 0) -> Capture:
    """A copy of ``capture`` with lower contrast and additive Gaussian noise.

    Each intensity becomes ``mean + contrast * (L - mean) + n``, n ~ N(0, noise_variance)
    independently per pixel and view, not clipped. Rendering is linear in the textures,
    so this equals scaling the textures' amplitude about ``mean``.
    """
    if contrast <= 0 or noise_variance < 0:
        raise ValueError(f"contrast = {contrast}, noise_variance = {noise_variance}; "
                         "expected contrast > 0 and noise_variance >= 0")
    rng = np.random.default_rng(seed)
    out = []
    for lf in capture.light_fields:
        lf = mean + contrast * (lf - mean)
        if noise_variance > 0:
            lf = lf + rng.normal(0.0, np.sqrt(noise_variance), lf.shape)
        out.append(lf.astype(np.float32))
    return replace(capture, light_fields=out)
