"""Scoring detections against synthetic scenes with known answers (the paper's noise
experiment's rules), for benchmarks/noise.py and its tests."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import cv2
import numpy as np

from liff.synthetic import Blob, match_blobs


@dataclass
class Score:
    """``found[i]``: blob i has a keypoint within max(2, radius/2) px of its centre;
    ``false_positives``: keypoints farther than radius + 2 px from every blob centre;
    ``slope_errors``: estimated minus true slope of the nearest keypoint of each found blob."""

    found: np.ndarray
    false_positives: int
    slope_errors: np.ndarray

    @property
    def tp_rate(self) -> float:
        return float(np.mean(self.found)) if len(self.found) else float("nan")


def score_blobs(keypoints: Sequence[cv2.KeyPoint], blobs: Sequence[Blob]) -> Score:
    """Scores keypoints against the blobs of a synthetic scene (see :class:`Score`)."""
    radii = np.array([b.radius for b in blobs], dtype=np.float64)
    match = match_blobs(keypoints, blobs, found_within=np.maximum(2.0, radii / 2),
                        spurious_beyond=radii + 2.0)
    return Score(match.found, match.spurious, match.slope_errors)


def above_threshold(keypoints: Sequence[cv2.KeyPoint], contrast_threshold: float,
                    n_octave_layers: int = 3) -> tuple:
    """The keypoints a detector with ``contrastThreshold = contrast_threshold`` would have
    kept: those with response >= contrast_threshold / n_octave_layers, from a run at a
    lower threshold. The final contrast test is this comparison; the pre-test at half of
    it could in principle drop a sample whose refinement more than doubles its |DoG|,
    which tests/benchmarks/test_scoring.py has not seen happen, so one run serves a whole
    threshold sweep."""
    limit = contrast_threshold / n_octave_layers
    return tuple(k for k in keypoints if k.response >= limit)
