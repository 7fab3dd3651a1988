"""Features at the views' borders (hostile files issue, border-aware features): near a
border, at a slope far from the scene's, the outer views' samples leave the frame and
the focal slice there averages fewer views, as sharp at a wrong slope as all of them at
the right one. A feature not every view sees at its slope is kept only where the views
that see it agree (docs/RESULTS.md, "Features at the views' borders")."""
import warnings

import numpy as np
import pytest

import liff
from liff import synthetic


def _wrong_slope_density(lf, slope, detector):
    """Wrong-slope features (more than 0.5 off) per 10^4 pixels within the band the
    outer views leave (plus 10 px) and inside it, and the right-slope features."""
    T, S, V, U = lf.shape
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", liff.SlopeRangeWarning)
        keypoints = detector.detect(lf)
    slopes = liff.keypoint_slopes(keypoints)
    pts = np.array([k.pt for k in keypoints])
    to_border = np.minimum.reduce([pts[:, 0], pts[:, 1], U - 1 - pts[:, 0], V - 1 - pts[:, 1]])
    band = abs(slope) * (max(T, S) - 1) / 2 + 10
    inner_area = (V - 2 * band) * (U - 2 * band)
    wrong = np.abs(slopes - slope) > 0.5
    at_border = (wrong & (to_border < band)).sum()
    inside = (wrong & (to_border >= band)).sum()
    return (1e4 * at_border / (V * U - inner_area), 1e4 * inside / inner_area,
            int((~wrong).sum()))


def test_the_borders_add_no_ghosts_of_their_own():
    """3x3 views of a plane at slope -4 whose world continues beyond the frame (a block
    of a gantry capture), two textures, a range set by hand 2 beyond either side:
    wrong-slope features are no denser at the borders than inside (before: 26 against
    17 per 10^4 px, the borders' own ghosts; after 13 against 17), and the right-slope
    features are those the automatic range finds (none of them dropped)."""
    border, inside = [], []
    for seed in (0, 1):
        lf = synthetic.textured_plane((3, 3, 256, 256), -4.0, seed)
        at_border, within, right = _wrong_slope_density(
            lf, -4.0, liff.LiFF.create(firstSlope=-6.0, lastSlope=6.0))
        border.append(at_border)
        inside.append(within)
        _, _, right_automatic = _wrong_slope_density(lf, -4.0, liff.LiFF.create())
        assert right == right_automatic
    assert np.mean(border) <= np.mean(inside), (border, inside)


@pytest.mark.parametrize("shape, x", [((5, 5, 96, 128), 4.3), ((1, 9, 80, 120), 9.3),
                                      ((9, 1, 120, 80), 9.3)])
@pytest.mark.parametrize("dtype", [np.float32, np.uint8])
def test_a_real_feature_that_some_views_do_not_see_is_kept(shape, x, dtype):
    """A disk near a border at its slope, outside some views (their shifted centre
    leaves the frame): the views that see it agree, so it is kept at its slope."""
    T, S, V, U = shape
    slope = 3.0
    along_x = S > 1
    blob = synthetic.Blob(x if along_x else U / 2 + 0.4, V / 2 + 0.6 if along_x else x, 2.5,
                          slope, 0.4)
    n = S if along_x else T
    centre = blob.x if along_x else blob.y
    side = U if along_x else V
    shifted = centre - slope * (np.arange(n) - (n - 1) / 2)
    assert ((shifted < 0) | (shifted > side - 1)).any()  # some views do not see it
    assert ((shifted >= 0) & (shifted <= side - 1)).mean() >= 0.5
    lf = synthetic.render_disks([blob], shape, noise_variance=1e-4, seed=2)
    if dtype == np.uint8:
        lf = np.clip(lf * 255 + 0.5, 0, 255).astype(np.uint8)
    detector = liff.LiFF.create(firstSlope=-4.0, lastSlope=4.0)
    keypoints = detector.detect(lf.astype(dtype, copy=False))
    near = [k for k in keypoints if np.hypot(k.pt[0] - blob.x, k.pt[1] - blob.y) < 2]
    assert near, "the disk is lost"
    assert np.abs(liff.keypoint_slopes(near) - slope).min() < 0.25
