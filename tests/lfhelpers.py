"""Helpers shared by the liff tests: scene builders and keypoint comparisons.

Imported as a plain module (pytest puts this folder on sys.path); fixtures that use
these live in conftest.py.
"""

from __future__ import annotations

import os
import struct
import threading
import time
import zlib
from pathlib import Path

import cv2
import numpy as np

import liff
from liff import synthetic


def assert_no_descriptors(desc, dtype=np.float32) -> None:
    """Descriptors of no features as the installed cv2.SIFT returns them: None with
    OpenCV 4, an empty (0, 128) array with OpenCV 5 (probed here, independently of
    liff's own probe)."""
    _, sift = cv2.SIFT.create().detectAndCompute(np.zeros((32, 32), np.uint8), None)
    if sift is None:
        assert desc is None
    else:
        assert isinstance(desc, np.ndarray) and desc.shape == (0, 128) and desc.dtype == dtype


def kp_fields(k: cv2.KeyPoint) -> tuple:
    """Every field of a keypoint, for exact comparisons."""
    return (k.pt[0], k.pt[1], k.size, k.angle, k.response, k.octave, k.class_id)


def assert_same_keypoints(a, b) -> None:
    """Asserts two keypoint sequences are equal field by field (bit for bit)."""
    assert len(a) == len(b), f"{len(a)} keypoints != {len(b)}"
    for i, (ka, kb) in enumerate(zip(a, b)):
        assert kp_fields(ka) == kp_fields(kb), f"keypoint {i}: {kp_fields(ka)} != {kp_fields(kb)}"


def assert_close_keypoints(a, b, atol: float = 1e-3) -> None:
    """Same count, same octaves; positions, sizes, angles, slopes within atol."""
    assert len(a) == len(b), f"{len(a)} keypoints != {len(b)}"
    fa = np.array([kp_fields(k) for k in a]).reshape(-1, 7)
    fb = np.array([kp_fields(k) for k in b]).reshape(-1, 7)
    np.testing.assert_allclose(fa[:, :3], fb[:, :3], atol=atol)  # x, y, size
    angle = np.abs(fa[:, 3] - fb[:, 3])
    assert np.all(np.minimum(angle, 360 - angle) < 100 * atol)
    np.testing.assert_allclose(fa[:, 6] / 65536, fb[:, 6] / 65536, atol=atol)  # slope


def points(kps) -> np.ndarray:
    """(N, 2) array of keypoint positions (x, y)."""
    return np.array([k.pt for k in kps], dtype=np.float64).reshape(-1, 2)


def nearest_distances(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """For each row of p, the distance to the nearest row of q (inf if q is empty)."""
    if len(q) == 0:
        return np.full(len(p), np.inf)
    return np.sqrt(((p[:, None, :] - q[None, :, :]) ** 2).sum(-1)).min(1)


def match_blobs(kps, blobs, tol: float = 1.0):
    """Pairs each blob with its nearest keypoint.

    Returns (found, slope_err, offset): a bool array (nearest keypoint within tol px),
    slope - true slope and (dx, dy) of the nearest keypoint for every blob.
    """
    pts, slopes = points(kps), liff.keypoint_slopes(kps)
    found = np.zeros(len(blobs), dtype=bool)
    slope_err = np.full(len(blobs), np.nan)
    offset = np.full((len(blobs), 2), np.nan)
    for i, b in enumerate(blobs):
        if len(pts) == 0:
            continue
        d = np.hypot(pts[:, 0] - b.x, pts[:, 1] - b.y)
        j = int(d.argmin())
        found[i] = d[j] <= tol
        slope_err[i] = slopes[j] - b.slope
        offset[i] = pts[j] - (b.x, b.y)
    return found, slope_err, offset


def blob_grid(shape, slopes, spacing=32, radius=(2.5, 3.5), seed=0):
    """Well-isolated Gaussian blobs on a regular grid, cycling through `slopes`.

    Unlike synthetic.random_blob_layers (neighbours as close as 4 radii, where even
    cv2.SIFT loses ~10% of blobs), every blob here is >= `spacing` px from the others.
    """
    T, S, V, U = shape
    rng = np.random.default_rng(seed)
    blobs = []
    for i, y in enumerate(np.arange(spacing / 2, V - spacing / 2 + 1, spacing)):
        for j, x in enumerate(np.arange(spacing / 2, U - spacing / 2 + 1, spacing)):
            k = len(blobs)
            jitter = rng.uniform(-2, 2, 2)
            blobs.append(
                synthetic.Blob(
                    float(x + jitter[0]), float(y + jitter[1]),
                    float(rng.uniform(*radius)), float(slopes[k % len(slopes)]),
                    0.4 if (i + j) % 2 else -0.4,
                )
            )
    return blobs


def texture(height: int, width: int, seed: int = 0, sigma: float = 2.0) -> np.ndarray:
    """Smoothed white noise scaled to [0, 1], float32."""
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.random((height, width)).astype(np.float32), (0, 0), sigma)
    return (t - t.min()) / (t.max() - t.min())


def textured_lf(shape, slope: int = 1, offset=(0, 0), seed: int = 0) -> np.ndarray:
    """A fronto-parallel textured plane at an integer slope (exact integer shifts).

    View (t, s) shows the texture shifted so that a point at (x, y) of the centre view
    is at (x - slope*(s - s_c), y - slope*(t - t_c)). `offset` (dx, dy) moves the
    camera: content at (x, y) for offset (0, 0) is at (x - dx, y - dy).
    T and S must be odd so the centre view is a real view.
    """
    T, S, V, U = shape
    assert T % 2 == 1 and S % 2 == 1 and max(abs(offset[0]), abs(offset[1])) <= 16
    pad = abs(slope) * max(T, S) + 20  # independent of offset: same texture for all
    tex = texture(V + 2 * pad, U + 2 * pad, seed)
    lf = np.empty(shape, np.float32)
    for t in range(T):
        for s in range(S):
            y0 = pad + offset[1] + slope * (t - (T - 1) // 2)
            x0 = pad + offset[0] + slope * (s - (S - 1) // 2)
            lf[t, s] = tex[y0:y0 + V, x0:x0 + U]
    return lf


def to_dtype(lf: np.ndarray, dtype) -> np.ndarray:
    """A [0, 1] float light field in `dtype` (integers scaled to their full range)."""
    dtype = np.dtype(dtype)
    if dtype.kind == "u":
        return np.round(np.clip(lf, 0, 1) * np.iinfo(dtype).max).astype(dtype)
    return lf.astype(dtype)


# ---------------------------------------------------------------- MATLAB / HDF5 files

def matlab_order(lf: np.ndarray) -> np.ndarray:
    """liff's (T, S, V, U[, C]) BGR(+weight) as MATLAB's LF(t, s, v, u, c) RGB(+weight)."""
    if lf.ndim == 5 and lf.shape[4] in (3, 4):
        return lf[..., [2, 1, 0, 3][: lf.shape[4]]]
    return lf


def write_mat_v5(path, variables: dict) -> None:
    """A MAT v5 file with scipy (dicts become structs), as MATLAB's ``save`` writes."""
    import scipy.io

    scipy.io.savemat(str(path), variables, do_compression=True)


MATLAB_V73_HEADER = (b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Nov 30 12:00:00 2026 "
                     b"HDF5 schema 1.00 .").ljust(116) + b"\x00" * 8 + b"\x00\x02IM"


def write_mat_v73(path, variables: dict) -> None:
    """A MAT v7.3 file as MATLAB's ``save -v7.3`` lays it out: HDF5 after a 512-byte user
    block holding the MATLAB header, arrays stored column-major (so h5py sees the axes
    reversed) with a ``MATLAB_class`` attribute, structs as groups."""
    import h5py

    classes = {np.dtype(np.uint8): "uint8", np.dtype(np.uint16): "uint16",
               np.dtype(np.float32): "single", np.dtype(np.float64): "double",
               np.dtype(bool): "logical", np.dtype(np.int16): "int16"}

    def put(group, name, value):
        if isinstance(value, dict):
            sub = group.create_group(name)
            sub.attrs["MATLAB_class"] = np.bytes_("struct")
            for key, item in value.items():
                put(sub, key, item)
            return
        if isinstance(value, str):  # char: UTF-16 code units, a 1 x N row
            dataset = group.create_dataset(name, data=np.array([[ord(c)] for c in value], np.uint16))
            dataset.attrs["MATLAB_class"] = np.bytes_("char")
            return
        value = np.asarray(value)
        stored = value.astype(np.uint8) if value.dtype == bool else value
        dataset = group.create_dataset(name, data=stored.transpose(tuple(range(value.ndim))[::-1]))
        dataset.attrs["MATLAB_class"] = np.bytes_(classes[value.dtype])

    with h5py.File(str(path), "w", userblock_size=512) as f:
        for name, value in variables.items():
            put(f, name, value)
    with open(path, "r+b") as f:
        f.write(MATLAB_V73_HEADER)


class Fifo:
    """A FIFO at ``path`` that never leaves a reader blocked: while it is open (a
    context), a thread lets each reader that opens it read an empty file at once, and
    counts them (``opened``), so that code that opens it fails instead of hanging."""

    def __init__(self, path):
        self.path = os.fspath(path)
        self.opened = 0
        os.mkfifo(self.path)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._release, daemon=True)

    def _release(self):
        while not self._stop.is_set():
            try:  # succeeds only while a reader has the FIFO open
                fd = os.open(self.path, os.O_WRONLY | os.O_NONBLOCK)
            except OSError:
                time.sleep(0.02)
                continue
            self.opened += 1
            os.close(fd)
            time.sleep(0.02)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()


def zero_png(path, width, height):
    """A valid grey PNG of width x height black pixels (rows compress to almost nothing)."""
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    packer, row = zlib.compressobj(9), b"\0" * (width + 1)
    idat = b"".join(packer.compress(row) for _ in range(height)) + packer.flush()
    Path(path).write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
                          + chunk(b"IDAT", idat) + chunk(b"IEND", b""))


def toolbox_H(h11=2e-4, h13=-1e-5, h15=0.0, h31=-2e-4, h33=2.5e-3, h35=0.0, views=9, pixels=301):
    """A plausible rectified H (square pixels, one baseline), recentred as the toolbox's
    LFRecenterIntrinsics does: the centre sample (1-based) maps to s = t = u = v = 0."""
    H = np.eye(5)
    H[0, 0] = H[1, 1] = h11
    H[0, 2] = H[1, 3] = h13
    H[2, 0] = H[3, 1] = h31
    H[2, 2] = H[3, 3] = h33
    centre = np.array([(views - 1) / 2 + 1, (views - 1) / 2 + 1, (pixels - 1) / 2 + 1 + 7,
                       (pixels - 1) / 2 + 1 - 4, 1.0])  # principal point off centre
    H[:4, 4] = 0
    H[:4, 4] = -(H @ centre)[:4]
    return H
