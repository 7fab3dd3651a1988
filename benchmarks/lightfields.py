"""Light fields for the benchmarks: textured, occluding fronto-parallel layers."""

from __future__ import annotations

import cv2
import numpy as np

ILLUM_SHAPE = (11, 11, 376, 541)  # Lytro Illum: 11x11 views of 376x541 pixels


def _texture(shape, seed, blur):
    rng = np.random.default_rng(seed)
    tex = cv2.GaussianBlur(rng.random(shape).astype(np.float32), (0, 0), blur)
    tex -= tex.min()
    return tex / max(float(tex.max()), 1e-6)


def layered_light_field(shape=ILLUM_SHAPE, seed=0, noise_variance=1e-4) -> np.ndarray:
    """Three textured layers at slopes -0.6, 0.1 and 0.7 (far to near); the middle
    one a disc, the near one vertical bars, each occluding what is behind it.

    Returns float32 (T, S, V, U) in [0, 1]. Rendering uses bilinear warps.
    """
    T, S, V, U = shape
    layers = [
        (-0.6, _texture((V, U), seed, 2.0), np.ones((V, U), np.float32)),
        (0.1, _texture((V, U), seed + 1, 1.5), None),
        (0.7, _texture((V, U), seed + 2, 1.0), None),
    ]
    yy, xx = np.mgrid[0:V, 0:U]
    layers[1] = (layers[1][0], layers[1][1],
                 ((xx - U * 0.45) ** 2 + (yy - V * 0.5) ** 2 < (0.3 * V) ** 2).astype(np.float32))
    layers[2] = (layers[2][0], layers[2][1], (np.mod(xx, 60) < 8).astype(np.float32))
    lf = np.zeros(shape, np.float32)
    noise = np.random.default_rng(seed + 9)
    for t in range(T):
        for s in range(S):
            view = np.zeros((V, U), np.float32)
            for slope, tex, alpha in layers:
                dx, dy = -slope * (s - (S - 1) / 2), -slope * (t - (T - 1) / 2)
                # Content at centre-view (x, y) appears at (x + dx, y + dy) in this view.
                M = np.float32([[1, 0, dx], [0, 1, dy]])
                warped = cv2.warpAffine(tex, M, (U, V), flags=cv2.INTER_LINEAR,
                                        borderMode=cv2.BORDER_REFLECT)
                a = cv2.warpAffine(alpha, M, (U, V), flags=cv2.INTER_LINEAR,
                                   borderMode=cv2.BORDER_REFLECT)
                view = view * (1 - a) + warped * a
            if noise_variance > 0:  # view by view, so memory stays at one light field
                view += noise.normal(0, np.sqrt(noise_variance), (V, U)).astype(np.float32)
            lf[t, s] = np.clip(view, 0, 1)
    return lf
