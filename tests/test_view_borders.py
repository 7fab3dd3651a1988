"""Features near the views' borders at large slopes (hostile files issue, borders):
a feature is kept only where every view sees its centre at its slope, the rule the
slope survey's coherence test already used (docs/SLOPES.md)."""

from __future__ import annotations

import numpy as np
import pytest

import liff
from liff.synthetic import textured_plane


def seen_by_every_view(keypoints, shape) -> np.ndarray:
    """Per keypoint: every view of ``shape`` sees its centre at its own slope."""
    T, S, V, U = shape
    slopes = np.abs(liff.keypoint_slopes(keypoints))
    pts = np.array([k.pt for k in keypoints]).reshape(-1, 2)
    rx, ry = slopes * (S - 1) / 2, slopes * (T - 1) / 2
    return ((pts[:, 0] - rx >= 0) & (pts[:, 0] + rx <= U - 1)
            & (pts[:, 1] - ry >= 0) & (pts[:, 1] + ry <= V - 1))


@pytest.mark.parametrize("shape, slope", [((3, 3, 128, 160), -4.0), ((1, 9, 96, 128), -2.0),
                                          ((4, 4, 96, 112), 1.5), ((7, 1, 120, 90), 2.5)])
def test_every_feature_is_seen_by_every_view_at_its_slope(shape, slope):
    """A hand-set range reaching far beyond the plane's slope, where the border bands
    of wrong slopes made ghosts: none is left whose centre some view cannot see, on
    grids, a row, a column and even view counts."""
    lf = textured_plane(shape, slope, seed=3)
    keypoints = liff.LiFF.create(firstSlope=-abs(slope) - 2, lastSlope=abs(slope) + 2).detect(lf)
    assert len(keypoints) > 20
    assert seen_by_every_view(keypoints, shape).all()


def test_features_every_view_sees_are_kept_up_to_the_band():
    """Features at the plane's own slope are still found next to the band that not
    every view sees (within 10 px of it), and their slopes are right."""
    shape, slope = (3, 3, 160, 200), 3.0
    T, S, V, U = shape
    keypoints = liff.LiFF.create().detect(textured_plane(shape, slope, seed=5))
    pts = np.array([k.pt for k in keypoints])
    band = slope * (S - 1) / 2
    to_border = np.minimum.reduce([pts[:, 0], pts[:, 1], U - 1 - pts[:, 0], V - 1 - pts[:, 1]])
    near = to_border < band + 10
    assert near.sum() >= 10
    assert np.all(np.abs(liff.keypoint_slopes(keypoints)[near] - slope) < 0.5)


def test_one_view_keeps_cv2_sifts_border():
    """With one view no band exists: an image's features near its border are kept as
    cv2.SIFT keeps them (tests/test_sift_parity.py checks the whole detection)."""
    image = textured_plane((1, 1, 96, 128), 0.0, seed=1)[0, 0]
    keypoints = liff.LiFF.create().detect(image)
    pts = np.array([k.pt for k in keypoints])
    assert np.min(np.minimum(pts[:, 0], pts[:, 1])) < 4
