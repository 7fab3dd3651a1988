"""ESLF (lenslet-interleaved) images, as in the Stanford Lytro light field archive.

An ESLF image stores the light field lenslet by lenslet: each n x n block of pixels is
one lenslet, pixel (t, s) of a block belonging to view (t, s). So view (t, s) is
``image[t::n, s::n]``. The archive's Lytro Illum files use n = 14 and carry an alpha
channel marking the samples that hold light (0 in the dark corners of each lenslet);
Illum captures decoded by the Light Field Toolbox (``LFUtilDecodeLytroFolder``,
``LFWriteESLF``) use n = 15. The toolbox's and the LiFF authors' readers
(``LFReadESLF.m``, ``LiFF_ReadESLF.m``) take n as an argument, 14 by default; here n is
detected from the image when not given (:func:`detect_lenslet_size`).
"""

from __future__ import annotations

import os
import warnings
from typing import Dict, Optional, Tuple

import numpy as np

from .._warnings import LensletSizeWarning
from ._shared import (
    LightFieldFile,
    PathLike,
    as_image,
    centre_range,
    centre_views,
    check_writable,
    positive_int,
    read_image,
    write_image,
)

LYTRO_LENSLET_SIZE = 14
#: lenslet sizes :func:`detect_lenslet_size` considers
LENSLET_SIZES = range(2, 33)
#: lenslets a signal must span on an axis for its period to count
MIN_LENSLETS = 8
# Thresholds (periodicity() scores of detrended profiles, benchmarks/lenslet_size.py):
# lenslet images (cotton as ESLF, n = 9; synthetic captures and plain layers, n = 9 to
# 16; liff synth disks as ESLF, 5x5 to 14x14 views, no vignetting) score 0.28-1.0 on
# both pixel profiles; images that are not lenslet-interleaved (cotton's centre view and
# mosaic, liff synth's mosaics, noise from 40x45 to 900x1000 pixels) score up to 0.5 on
# one profile, but at most 0.16 on both at one period (a mosaic's tiles repeat along
# one axis by chance; lenslets are square and show along both).
#: share of a signal's variance a period must explain to be taken on its own ...
STRONG_PERIODICITY = 0.3
#: ... or, when the size also divides the image's height and width, at least this share
WEAK_PERIODICITY = 0.2
#: the pairs of profiles of which one must show the period along both axes
AXIS_PAIRS = (("rows", "columns"), ("alpha rows", "alpha columns"))
#: rows (columns) sampled to build a profile along the columns (rows)
PROFILE_LINES = 256


def periodicity(profile: np.ndarray, sizes=LENSLET_SIZES) -> Dict[int, float]:
    """{n: share of the variance of ``profile`` explained by a period of n samples}.

    The share is ``var(phase means) / var(profile)`` over the whole periods of the
    profile (the R^2 of a model that repeats every n samples), adjusted for chance: a
    model with n free values explains about ``(n - 1) / (len - 1)`` of noise, so the
    score is ``(R^2 - chance) / (1 - chance)``: 1 for a profile that repeats exactly
    every n samples (and every multiple of n), about 0 for noise. Sizes with fewer than
    ``MIN_LENSLETS`` periods in the profile are left out.

    Before folding, the profile's mean over each window of n samples is subtracted
    (which leaves a period of n as it is): what varies over many lenslets (the tiles of
    a mosaic, shading, the scene's large shapes) would otherwise be explained in part by
    any long period.
    """
    profile = np.asarray(profile, np.float64)
    sums = np.concatenate([[0.0], np.cumsum(profile)])
    scores = {}
    for n in sizes:
        if len(profile) // n < MIN_LENSLETS:
            continue
        window_means = (sums[n:] - sums[:-n]) / n  # mean of profile[i:i + n]
        detrended = profile[n // 2: n // 2 + len(window_means)] - window_means
        periods = len(detrended) // n  # (one fewer than the profile's when n divides it)
        folded = detrended[: periods * n].reshape(periods, n)
        total = folded.var()
        explained = folded.mean(axis=0).var() / total if total > 0 else 0.0
        chance = (n - 1) / (periods * n - 1)
        scores[n] = float(max(0.0, (explained - chance) / (1 - chance)))
    return scores


def best_period(scores: Dict[int, float]) -> Tuple[Optional[int], float]:
    """(n, score): the smallest n scoring at least 0.9 of the best score (a period's
    multiples explain the profile as well as the period itself), or (None, 0.0)."""
    if not scores or max(scores.values()) <= 0:
        return None, 0.0
    top = max(scores.values())
    n = min(n for n, score in scores.items() if score >= 0.9 * top)
    return n, scores[n]


def _profiles(image: np.ndarray, has_alpha: bool) -> Dict[str, np.ndarray]:
    """The 1-D signals whose period is the lenslet size, on a sample of lines.

    ``rows`` / ``columns``: the mean absolute difference between neighbouring pixels
    along the rows (a function of the column) and along the columns. Neighbouring pixels
    of one lenslet are neighbouring views of one scene point and differ little; the two
    sides of a lenslet boundary are views from opposite ends of the aperture of
    neighbouring points and differ more, and vignetting darkens the same lenslet pixels
    everywhere. ``alpha rows`` / ``alpha columns``: the mean alpha along each axis, when
    there is an alpha channel that is not constant.
    """
    height, width = image.shape[:2]
    rng = np.random.default_rng(0)  # random lines, so that their phases in the lenslets vary
    rows = np.sort(rng.choice(height, min(height, PROFILE_LINES), replace=False))
    cols = np.sort(rng.choice(width, min(width, PROFILE_LINES), replace=False))
    channels = image.shape[2]
    colour = slice(0, channels - 1) if has_alpha else slice(0, channels)
    across = image[rows][..., colour].astype(np.float32).mean(axis=2)  # (lines, width)
    down = image[:, cols][..., colour].astype(np.float32).mean(axis=2)  # (height, lines)
    profiles = {"rows": np.abs(np.diff(across, axis=1)).mean(axis=0),
                "columns": np.abs(np.diff(down, axis=0)).mean(axis=1)}
    if has_alpha:
        alpha_across = image[rows][..., -1].astype(np.float32).mean(axis=0)
        alpha_down = image[:, cols][..., -1].astype(np.float32).mean(axis=1)
        if np.ptp(alpha_across) > 0 or np.ptp(alpha_down) > 0:
            profiles["alpha rows"] = alpha_across
            profiles["alpha columns"] = alpha_down
    return profiles


def detect_lenslet_size(image: np.ndarray, has_alpha: Optional[bool] = None,
                        source: str = "image") -> Tuple[int, dict]:
    """The lenslet size n of an ESLF image, from the image itself.

    Three cues are used: the period of the alpha channel (the dark lenslet corners),
    when there is one that varies; the period of the pixel content along the rows and
    along the columns (see ``_profiles``); and whether n divides the image's height and
    width. A period that explains at least ``STRONG_PERIODICITY`` of a profile's
    variance counts on its own, one that explains ``WEAK_PERIODICITY`` only if it
    divides the image size too. All the profiles that count must agree, and the period
    must count along both axes, in the pixels (``rows`` and ``columns``) or the alpha:
    lenslets are square, while one profile alone may show a period by chance (the tiles
    of a mosaic).

    Parameters
    ----------
    image : ndarray, shape (height, width) or (height, width, C)
        The ESLF image as read (C = 2 or 4: the last channel is alpha).
    has_alpha : bool, optional
        Whether the last channel is alpha; default: C is 2 or 4.
    source : str
        Named in errors and warnings (the file).

    Returns
    -------
    n : int
    evidence : dict
        {profile name: (its best period, the share of variance it explains)}.

    Raises
    ------
    ValueError
        If no period shows along both axes (e.g. an image that is not
        lenslet-interleaved, or too small to hold ``MIN_LENSLETS`` lenslets a side), or
        the profiles disagree.
        Pass the size explicitly then.

    Warns
    -----
    LensletSizeWarning
        When the detected n does not divide the image size but another candidate does.
    """
    if image.ndim == 2:
        image = image[:, :, None]
    if has_alpha is None:
        has_alpha = image.shape[2] in (2, 4)
    height, width = image.shape[:2]
    evidence = {name: best_period(periodicity(profile))
                for name, profile in _profiles(image, has_alpha).items()}

    def divides(n: int) -> bool:
        return height % n == 0 and width % n == 0

    counted = {name: n for name, (n, score) in evidence.items()
               if n is not None and (score >= STRONG_PERIODICITY
                                     or (score >= WEAK_PERIODICITY and divides(n)))}
    described = ", ".join(f"{name}: {'-' if n is None else n} ({score:.2f})"
                          for name, (n, score) in evidence.items())
    sizes = sorted(set(counted.values()))
    if len(sizes) > 1:
        raise ValueError(f"{source}: the lenslet size is ambiguous: {described}; expected the "
                         f"profiles to agree, or the size given (n=N)")
    if not any(all(name in counted for name in pair) for pair in AXIS_PAIRS):
        # (one axis alone: a mosaic's tiles, a texture; lenslets are square)
        raise ValueError(f"{source}: cannot tell the lenslet size from the image ({width}x{height}; "
                         f"best period and share of variance explained per profile: "
                         f"{described}; a size is taken when one period shows along both rows "
                         f"and columns, in the pixels or the alpha, explaining at least "
                         f"{STRONG_PERIODICITY:g} of each, or {WEAK_PERIODICITY:g} where it "
                         f"divides the image); expected an ESLF image whose lenslets show in its "
                         f"pixels or alpha, or the size given (n=N)")
    n = sizes[0]
    if not divides(n):
        others = sorted((m for m in LENSLET_SIZES if m > 2 and divides(m) and m % n and n % m),
                        key=lambda m: abs(m - n))
        if others:
            warnings.warn(f"{source}: lenslet size {n} detected ({described}), but the image "
                          f"({width}x{height}) is a whole number of {others[0]}-pixel lenslets, "
                          f"not {n}-pixel ones; give the size (n=N) if {n} is wrong",
                          LensletSizeWarning, stacklevel=3)
    return n, {name: (m, round(score, 3)) for name, (m, score) in evidence.items()}


def read_eslf(path: PathLike, n: Optional[int] = None, keep=None) -> LightFieldFile:
    """Reads an ESLF image.

    Parameters
    ----------
    path : path
        The image (any format OpenCV reads; ``cv2.IMREAD_UNCHANGED``).
    n : int, optional
        Lenslet size in pixels (views per row and per column of the lenslet grid); a
        whole number >= 2 (2.0 is taken as 2, 2.5 and 1 are refused). Default: detected from the
        image (:func:`detect_lenslet_size`: the period of its alpha channel and of its
        pixels along rows and columns, and the image size); an image whose lenslet size
        cannot be told is refused. The Stanford Lytro archive uses 14, the Light Field
        Toolbox's decoded Illum captures 15.
    keep : int or (int, int), optional
        Keep only the centre ``keep`` x ``keep`` views (or keep_t x keep_s). The first
        kept view is ``(n - keep) // 2`` on each axis, so an odd number of dropped views
        drops the extra one at the bottom / right: n = 14, keep = 11 keeps views 1..11
        (0-based), the paper's choice for Lytro data.

    Returns
    -------
    LightFieldFile
        ``light_field`` (T, S, V, U[, C]) with V = height // n, U = width // n: rows and
        columns past the last whole lenslet are dropped. An alpha channel is kept as the
        last channel (BGRA: C = 4, grey + alpha: C = 2): it is the per-sample validity
        weight. ``metadata``: ``lenslet_size``, ``lenslet_size_detected`` (False when
        ``n`` was given), ``lenslet_evidence`` (per profile: its period and the share of
        variance it explains; empty when ``n`` was given), ``first_view`` (t, s) within
        the lenslet, ``image_size`` (height, width), ``cropped`` (rows, columns dropped
        at the bottom / right), ``has_alpha``.

    Raises
    ------
    ValueError
        Naming the file: unreadable, ``n`` not a whole number >= 2 (a lenslet of one
        pixel is one view: an ordinary image), ``keep`` not a whole number >= 1, a
        lenslet size that cannot be detected, an image smaller than one lenslet, or
        ``keep`` larger than ``n``. (The ``liff`` command asks more of a given size:
        :func:`check_given_lenslets`.)

    Warns
    -----
    LensletSizeWarning
        When the detected size does not divide the image size and another one does.
    """
    path = os.fspath(path)
    detected = n is None
    size = 0  # the lenslet size n, given or detected
    if n is not None:
        size = positive_int(n, "lenslet size n", path, 2, "a whole number of pixels >= 2 (each "
                            "lenslet holds n x n views; n = 1 is an ordinary image)")
    image = read_image(path, copies=2)  # the image and the light field rearranged from it
    evidence: dict = {}
    if detected:
        size, evidence = detect_lenslet_size(image, source=path)
    n = size
    height, width = image.shape[:2]
    V, U = height // n, width // n
    if V == 0 or U == 0:
        raise ValueError(f"{path}: image is {width}x{height}; expected at least one {n}x{n} "
                         f"lenslet")
    if image.ndim == 2:
        image = image[:, :, None]
    channels = image.shape[2]
    # (V, n, U, n, C) -> (t, s, v, u, c): pixel (v * n + t, u * n + s) is view (t, s)'s (v, u)
    blocks = image[: V * n, : U * n].reshape(V, n, U, n, channels).transpose(1, 3, 0, 2, 4)
    first = (0, 0)
    if keep is not None:
        try:
            blocks = centre_views(blocks, keep)
        except ValueError as e:
            raise ValueError(f"{path}: {e}") from None
        first = (centre_range(n, blocks.shape[0]).start, centre_range(n, blocks.shape[1]).start)
    light_field = np.ascontiguousarray(blocks if channels > 1 else blocks[..., 0])
    metadata = {"lenslet_size": n, "lenslet_size_detected": detected,
                "lenslet_evidence": evidence, "first_view": first,
                "image_size": (height, width), "cropped": (height - V * n, width - U * n),
                "has_alpha": channels in (2, 4)}
    return LightFieldFile(light_field, "eslf", metadata, None, path)


def check_given_lenslets(result: LightFieldFile) -> None:
    """Refuses a lenslet image read with a given size ``n`` that makes fewer than
    :data:`MIN_LENSLETS` (8) lenslets a side, views smaller than 8 x 8 pixels: what
    :func:`detect_lenslet_size` needs to see a lenslet period, and less than a feature
    needs. Such an image is a thumbnail, or ``n`` is not its lenslet size. The ``liff``
    command applies it to ``--lenslet``; :func:`read_eslf` itself reads any image of at
    least one lenslet (small light fields round-trip).

    Raises
    ------
    ValueError
        Naming the file, its size, the lenslets ``n`` makes and the size ``n`` needs.
    """
    meta = result.metadata
    if result.format != "eslf" or meta.get("lenslet_size_detected", True):
        return
    n, (height, width) = meta["lenslet_size"], meta["image_size"]
    U, V = width // n, height // n
    if min(U, V) < MIN_LENSLETS:
        raise ValueError(f"{result.source}: image is {width}x{height}: {U}x{V} lenslets of {n}x{n} "
                         f"pixels (n={n}); expected at least {MIN_LENSLETS} lenslets a side, an "
                         f"image of at least {MIN_LENSLETS * n}x{MIN_LENSLETS * n} pixels (views "
                         f"of at least {MIN_LENSLETS}x{MIN_LENSLETS} pixels, as the lenslet size "
                         "detection needs): a thumbnail, or not this image's lenslet size")


def write_eslf(path: PathLike, light_field: np.ndarray, n: Optional[int] = None) -> None:
    """Writes a light field as an ESLF image.

    Parameters
    ----------
    path : path
        Image path; its ending picks the format (.png keeps alpha and 16 bits).
    light_field : ndarray, shape (T, S, V, U[, C])
        uint8, or uint16 for .png/.tif; C in {1, 3, 4}.
    n : int, optional
        Lenslet size, at least max(T, S) (the default). With a larger ``n`` the views
        are placed where ``read_eslf(path, n, keep=(T, S))`` finds them again and the
        other lenslet samples are 0 (alpha 0 too, so they read back as invalid).

    Raises
    ------
    ValueError
        If the light field cannot be stored in that image format or ``n`` is too small.
    """
    path = os.fspath(path)
    light_field = check_writable(light_field, path)
    T, S, V, U = light_field.shape[:4]
    n = positive_int(max(T, S) if n is None else n, "lenslet size n", path, max(T, S))
    channels = light_field.shape[4:]
    lenslets = np.zeros((n, n, V, U) + channels, light_field.dtype)
    lenslets[centre_range(n, T), centre_range(n, S)] = light_field
    image = lenslets.transpose((2, 0, 3, 1) + tuple(range(4, 4 + len(channels))))
    write_image(path, as_image(image.reshape((V * n, U * n) + channels)))
