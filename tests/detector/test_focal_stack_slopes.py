"""The focal stack's slopes: automatic by default (docs/SLOPES.md), hand-set with their
exact meaning, the spacing rule, sub-slice slopes and the range-end warning."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import liff
from lfhelpers import assert_no_descriptors, assert_same_keypoints
from liff import synthetic


def blob_layers(slopes, n=5, size=160, seed=0, per_layer=5):
    shape = (n, n, size, size)
    blobs = synthetic.random_blob_layers(slopes, shape, blobs_per_layer=per_layer,
                                         radius_range=(2.5, 5.0), seed=seed, margin=14)
    lf = synthetic.render_disks(blobs, shape, profile="gaussian", noise_variance=1e-5, seed=seed)
    return np.clip(lf, 0, 1).astype(np.float32), blobs


def matched(keypoints, blobs):
    radii = np.array([b.radius for b in blobs])
    return synthetic.match_blobs(keypoints, blobs, np.maximum(2.0, radii / 2), radii + 2.0)


@pytest.fixture(scope="module")
def far_layers():
    """5x5 views of 160x160: blob layers at -2.5, 0.5 and 2.5, far outside [-1, 1] on
    both sides, with an empty gap between -2.5 and 0.5."""
    return blob_layers([-2.5, 0.5, 2.5])


def test_automatic_range_is_the_default_and_round_trips(tmp_path):
    d = liff.LiFF.create()
    assert d.getFirstSlope() == -math.inf and d.getLastSlope() == math.inf
    path = str(tmp_path / "d.yml")
    d.save(path)
    e = liff.LiFF.create(firstSlope=-1, lastSlope=1)
    e.read(path)
    assert e.getFirstSlope() == -math.inf and e.getLastSlope() == math.inf
    e.setFirstSlope(-2.0)  # half automatic: a finite lower bound
    assert e.getFirstSlope() == -2.0 and e.getLastSlope() == math.inf
    with pytest.raises(ValueError, match="firstSlope"):
        e.setFirstSlope(math.inf)  # +inf is not the automatic side of firstSlope


def test_layers_far_outside_the_papers_range_are_found_at_their_slopes(far_layers):
    lf, blobs = far_layers
    d = liff.LiFF.create()
    kps = d.detect(lf)
    match = matched(kps, blobs)
    slopes = np.array([b.slope for b in blobs])
    for layer in (-2.5, 0.5, 2.5):
        assert match.found[slopes == layer].mean() >= 0.6, layer
    assert np.median(np.abs(match.slope_errors)) < 0.02
    # No feature at an end of the searched slopes: every searched slice has both
    # neighbours, so none is pinned there.
    searched, used = d.getSearchedSlopes(), d.getSlicesUsed()
    tol = 1 / liff.SLOPE_SCALE
    found = liff.keypoint_slopes(kps)
    assert not np.any(np.abs(found - searched[0]) <= tol)
    assert not np.any(np.abs(found - searched[-1]) <= tol)
    assert used[0] < searched[0] and used[-1] > searched[-1]


def test_empty_slope_intervals_are_skipped_and_searched_slices_have_both_neighbours(far_layers):
    lf, _ = far_layers
    d = liff.LiFF.create()
    d.detect(lf)
    spacing = 2 / (5 - 1)
    searched, used = np.array(d.getSearchedSlopes()), np.array(d.getSlicesUsed())
    assert not np.any((searched > -1.6) & (searched < -0.4))  # the gap between layers
    for m in searched:
        assert np.min(np.abs(used - (m - spacing))) < 1e-9
        assert np.min(np.abs(used - (m + spacing))) < 1e-9
    assert np.allclose(np.round(used / spacing) * spacing, used)  # one grid, through 0
    assert d.slopesFor(lf) == list(used)  # the survey alone gives the same plan


def test_hand_set_range_keeps_its_exact_meaning(far_layers):
    lf, _ = far_layers
    d = liff.LiFF.create(firstSlope=-1, lastSlope=1)
    kps = d.detect(lf)
    assert d.getSlicesUsed() == d.slopesFor(5, 5) == pytest.approx(np.linspace(-1, 1, 5))
    assert d.getSearchedSlopes() == d.getSlicesUsed()
    slopes = liff.keypoint_slopes(kps)
    assert slopes.min() >= -1 - 1e-6 and slopes.max() <= 1 + 1e-6


@pytest.mark.parametrize("T, S, first, last, expected", [
    (9, 9, -1, 1, 9), (3, 3, -6, 6, 13), (5, 5, -0.3, 0.3, 3), (4, 4, -1, 1, 5),
    (15, 15, -4, 3, 51), (1, 7, 0, 1, 5),
])
def test_slice_spacing_is_one_pixel_at_the_outermost_view(T, S, first, last, expected):
    slopes = liff.LiFF.create(firstSlope=first, lastSlope=last).slopesFor(T, S)
    assert len(slopes) == expected
    assert np.max(np.diff(slopes)) <= 2 / (max(T, S) - 1) + 1e-12


def test_explicit_numslopes_with_an_automatic_range(far_layers):
    """numSlopes = n with an automatic range: n evenly spaced slices from the first to
    the last slope the default would search, plus an unsearched guard beyond each end,
    so that the outer layers (at -2.5 and 2.5) keep sub-slice slopes, not end ones."""
    lf, blobs = far_layers
    d = liff.LiFF.create(numSlopes=7)
    keypoints = d.detect(lf)
    used, searched = d.getSlicesUsed(), d.getSearchedSlopes()
    assert len(used) == 7 and searched == used[1:-1]
    assert used[1] <= -2.5 <= used[2] and used[-3] <= 2.5 <= used[-2]
    assert np.allclose(np.diff(used), np.diff(used)[0])
    slopes = liff.keypoint_slopes(keypoints)
    assert not np.any(np.isclose(slopes, searched[0], atol=1e-4) | np.isclose(slopes, searched[-1], atol=1e-4))
    match = matched(keypoints, blobs)
    # (1.4 apart, coarser than the default 0.5, a faint blob may drop out)
    assert len(match.slope_errors) >= 0.9 * len(blobs) and np.max(np.abs(match.slope_errors)) < 0.25


@pytest.mark.parametrize("n", [3, 4])
def test_numslopes_too_few_for_guards_are_all_searched(far_layers, n):
    """Guards would leave fewer than three searched slices, too far apart to place a
    feature between them: all n are searched, as a hand-set range."""
    lf, _ = far_layers
    d = liff.LiFF.create(numSlopes=n)
    d.detect(lf)
    assert len(d.getSlicesUsed()) == n and d.getSearchedSlopes() == d.getSlicesUsed()


@pytest.mark.parametrize("bounds", [{"lastSlope": 6.0}, {"firstSlope": -6.0}])
def test_numslopes_with_a_far_finite_bound_keeps_a_guard_on_that_side(far_layers, bounds):
    """A finite bound well beyond the scene: the plan's end on that side is not the
    bound's slice, so it gets a guard too, and the outer layer keeps its slope."""
    lf, blobs = far_layers
    d = liff.LiFF.create(numSlopes=7, **bounds)
    keypoints = d.detect(lf)
    used, searched = d.getSlicesUsed(), d.getSearchedSlopes()
    assert searched == used[1:-1]
    match = matched(keypoints, blobs)
    assert len(match.slope_errors) >= 0.9 * len(blobs) and np.max(np.abs(match.slope_errors)) < 0.25


def test_half_automatic_range_stays_within_its_finite_bound(far_layers):
    lf, _ = far_layers
    d = liff.LiFF.create(firstSlope=0.0)  # lastSlope stays automatic
    slopes = liff.keypoint_slopes(d.detect(lf))
    assert len(slopes) and slopes.min() >= 0.0
    assert np.any(np.abs(slopes - 2.5) < 0.1)


@pytest.mark.parametrize("bounds", [{"firstSlope": -2.6}, {"lastSlope": 2.6}])
def test_half_automatic_grid_has_a_slice_at_its_finite_bound(far_layers, bounds):
    """The finite bound is a slice, not rounded inward to the default grid (where
    features between the bound and the first slice would be pinned there)."""
    lf, _ = far_layers
    d = liff.LiFF.create(**bounds)
    d.detect(lf)
    bound = bounds.get("firstSlope", bounds.get("lastSlope"))
    end = d.getSlicesUsed()[0] if "firstSlope" in bounds else d.getSlicesUsed()[-1]
    assert end == pytest.approx(bound)
    assert np.allclose(np.diff(d.getSlicesUsed()) % 0.5, 0, atol=1e-9) or \
        np.allclose(np.diff(d.getSlicesUsed()) % 0.5, 0.5, atol=1e-9)


def test_half_automatic_range_does_not_pin_a_layer_beyond_its_bound(far_layers):
    """The survey stays within the finite bound: the layer at -2.5, beyond a bound of
    -2.3, is left out rather than reported at the bound."""
    lf, _ = far_layers
    slopes = liff.keypoint_slopes(liff.LiFF.create(firstSlope=-2.3).detect(lf))
    assert len(slopes) and slopes.min() > -2.0


@pytest.mark.parametrize("shape", [(2, 2, 128, 128), (1, 2, 160, 160)])
def test_two_views_use_a_narrow_range(shape):
    """Two views along the longer axis: a wide survey finds ghosts of textures at every
    slope (docs/SLOPES.md, "Two views"); the automatic range is [-2, 2] and the slopes
    of textured layers within it stay right."""
    scene = synthetic.textured_layers(shape, (-0.9, 0.13, 0.77), seed=0)
    d = liff.LiFF.create()
    keypoints = d.detect(scene.light_field)
    assert d.getSlicesUsed() == [-2.0, 0.0, 2.0]
    pts = np.rint([k.pt for k in keypoints]).astype(int)
    errors = np.abs(liff.keypoint_slopes(keypoints) - scene.slope_map[pts[:, 1], pts[:, 0]])
    assert len(errors) > 100 and np.mean(errors > 1) < 0.2
    assert len(liff._core._hooks.survey(d, scene.light_field)) == 0  # no survey, no ghost warning


@pytest.mark.parametrize("bounds, expected", [
    ({"firstSlope": -0.5}, (-0.5, 2.0)), ({"lastSlope": 1.0}, (-2.0, 1.0)),
    ({"firstSlope": -8187.0}, (-2.0, 2.0)), ({"firstSlope": 3.0}, (3.0, 7.0)),
    ({"lastSlope": -5.0}, (-9.0, -5.0))])
def test_two_views_half_automatic_ranges_stay_narrow(bounds, expected):
    scene = synthetic.textured_layers((2, 2, 64, 64), (-0.5, 0.0, 0.5), seed=0)
    d = liff.LiFF.create(**bounds)
    d.detect(scene.light_field)
    used = d.getSlicesUsed()
    assert (used[0], used[-1]) == pytest.approx(expected)


def test_no_feature_with_the_automatic_range_warns_of_its_bound():
    """17x17 views of 64 pixels consider slopes within +-1 only (docs/SLOPES.md); layers
    at -1.5 and 1.2 give no feature: the warning names the bound and what to set."""
    lf, _ = blob_layers([-1.5, 1.2], n=17, size=64, per_layer=4)
    with pytest.warns(liff.SlopeRangeWarning, match=r"within \+-1\.00 .*set firstSlope and lastSlope"):
        assert len(liff.LiFF.create().detect(lf)) == 0
    found = liff.LiFF.create(firstSlope=-2, lastSlope=2).detect(lf)
    assert len(found) > 0


def test_views_too_small_to_survey_search_every_slope_up_to_the_bound():
    """9x9 views of 63 pixels are not surveyed; a layer at slope 2 (just past
    R = 63 / 32) is still searched, the bound rounded outward to the grid."""
    lf, blobs = blob_layers([2.0], n=9, size=63, per_layer=4)
    d = liff.LiFF.create()
    match = matched(d.detect(lf), blobs)
    assert len(match.slope_errors) == len(blobs) and np.max(np.abs(match.slope_errors)) < 0.05


@pytest.mark.parametrize("value", [0.0, 0.5, 1.0])
def test_constant_and_blank_light_fields_give_no_features_and_no_error(value):
    lf = np.full((5, 5, 96, 96), value, np.float32)
    d = liff.LiFF.create()
    kps, desc = d.detectAndCompute(lf)
    assert kps == ()
    assert_no_descriptors(desc)
    assert len(d.getSlicesUsed()) >= 1


def test_two_dimensional_input_is_unchanged(texture_image):
    """A single view has one slice at slope 0, exactly as the explicit [-1, 1] gave."""
    auto = liff.LiFF.create()
    explicit = liff.LiFF.create(firstSlope=-1, lastSlope=1)
    a, da = auto.detectAndCompute(texture_image)
    b, db = explicit.detectAndCompute(texture_image)
    assert_same_keypoints(a, b)
    np.testing.assert_array_equal(da, db)
    assert auto.getSlicesUsed() == [0.0] and auto.slopesFor(1, 1) == [0.0]


def test_slopes_for_view_counts_needs_a_light_field_when_automatic(far_layers):
    with pytest.raises(ValueError, match="slopesFor\\(lightField\\)"):
        liff.LiFF.create().slopesFor(5, 5)
    lf, _ = far_layers
    assert liff.LiFF.create().slopesFor(lf) == sorted(liff.LiFF.create().slopesFor(lf))


@pytest.mark.parametrize("bounds", [{}, {"firstSlope": -2.6}, {"lastSlope": 2.6}])
def test_compute_describes_on_the_slices_detection_used(far_layers, bounds):
    lf, _ = far_layers
    d = liff.LiFF.create(**bounds)
    kps, desc = d.detectAndCompute(lf)
    again, desc2 = d.compute(lf, kps)
    assert_same_keypoints(again, kps)
    np.testing.assert_array_equal(desc2, desc)


def test_sub_slice_slopes_stay_accurate_with_coarse_spacing():
    """Five slices over [-2, 2] for 9x9 views: a spacing of four pixels of parallax at
    the outermost view. The Gaussian fit keeps slopes close (observed median 0.006;
    the parabola through the DoG values gave 0.035)."""
    lf, blobs = blob_layers([-1.3, -0.4, 0.6, 1.45], n=9, size=128, seed=3, per_layer=4)
    kps = liff.LiFF.create(firstSlope=-2, lastSlope=2, numSlopes=5).detect(lf)
    match = matched(kps, blobs)
    assert match.found.mean() >= 0.8
    assert np.median(np.abs(match.slope_errors)) < 0.015


def test_hand_set_range_that_cuts_the_scene_warns_with_a_range_that_holds_it(far_layers):
    lf, _ = far_layers
    with pytest.warns(liff.SlopeRangeWarning, match=r"sit at an end of the slope range "
                                                   r"\[-1, 1\].*try firstSlope=-2\.\d+, lastSlope=2\.\d+"):
        liff.LiFF.create(firstSlope=-1, lastSlope=1).detect(lf)
    with warnings.catch_warnings():
        warnings.simplefilter("error", liff.SlopeRangeWarning)
        liff.LiFF.create().detect(lf)  # automatic: never
        liff.LiFF.create(firstSlope=-3, lastSlope=3).detect(lf)  # holds the scene


def test_features_at_the_scenes_own_ends_do_not_warn():
    """Layers exactly at -1 and +1 searched over [-1, 1]: their features sit at the
    range's ends, which is where the scene ends too."""
    lf, _ = blob_layers([-1.0, 1.0], seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", liff.SlopeRangeWarning)
        kps = liff.LiFF.create(firstSlope=-1, lastSlope=1).detect(lf)
    slopes = liff.keypoint_slopes(kps)
    assert np.mean(np.isclose(np.abs(slopes), 1.0, atol=1e-4)) > 0.05


def test_few_views_with_textures_keep_a_tight_range():
    """3x3 views of textured layers within [-0.3, 0.3]: at wrong slopes the nine copies
    of a texture make random extrema; the survey's coherence and density tests keep
    them from claiming slopes far away."""
    scene = synthetic.textured_layers((3, 3, 160, 160), (-0.3, 0.0, 0.3), seed=4)
    d = liff.LiFF.create()
    d.detect(scene.light_field)
    searched = d.getSearchedSlopes()
    assert -3 <= searched[0] and searched[-1] <= 3


@pytest.mark.parametrize("n", [3, 9])
def test_a_fine_texture_alone_at_a_distant_slope_is_found(n):
    """The bars of textured_layers (a 1 px texture, the only structure near +3) vanish
    in the survey's decimated levels; the plane sweep at half resolution sees them
    (docs/SLOPES.md), so the default range reaches them."""
    scene = synthetic.textured_layers((n, n, 256, 256), (-4.0, -0.5, 3.0), seed=2)
    d = liff.LiFF.create()
    slopes = liff.keypoint_slopes(d.detect(scene.light_field))
    for layer in (-4.0, -0.5, 3.0):
        assert np.sum(np.abs(slopes - layer) <= 0.1) >= 5, layer
    searched = d.getSearchedSlopes()
    assert searched[0] < -4.0 < searched[-1] and searched[0] < 3.0 < searched[-1]


@pytest.mark.parametrize("noise, found", [(1e-3, (-2.0, 0.5, 2.5)), (1e-2, (-2.0, 0.5))])
def test_low_contrast_layers_in_noise_are_found(noise, found):
    """Textured layers of contrast 0.3 under view noise (9x9 views): the survey's
    decimated levels see no feature at the default contrast threshold. At variance 1e-3
    the plane sweep finds every layer; at 1e-2 it finds none, and the survey's second
    look at half the threshold finds the two coarser layers (before both, the range fell
    back to the paper's [-1, 1] and kept the layer at 0.5 alone)."""
    scene = synthetic.textured_layers((9, 9, 256, 256), (-2.0, 0.5, 2.5), seed=2,
                                      noise_variance=noise, contrast=0.3)
    slopes = liff.keypoint_slopes(liff.LiFF.create().detect(scene.light_field))
    for layer in found:
        assert np.sum(np.abs(slopes - layer) <= 0.1) >= 5, layer


def test_lone_survey_features_are_searched_when_they_are_all_there_is():
    """One blob per layer at -3 and +3: no surveyed slope has another near it. Lone
    features do not claim slices when others have support, but when none has (and the
    sweep finds nothing) they are all there is (the plan was empty: no feature)."""
    shape = (5, 5, 128, 128)
    blobs = synthetic.random_blob_layers([-3.0, 3.0], shape, blobs_per_layer=1, seed=0, margin=20)
    lf = synthetic.render_disks(blobs, shape, profile="gaussian")
    d = liff.LiFF.create()
    slopes = liff.keypoint_slopes(d.detect(lf))
    for layer in (-3.0, 3.0):
        assert np.sum(np.abs(slopes - layer) <= 0.1) >= 2, layer


@pytest.mark.parametrize("bounds", [dict(firstSlope=2.6), dict(lastSlope=-5.0)])
def test_half_automatic_bound_beyond_all_structure_searches_from_the_bound(bounds):
    """Every layer lies beyond the finite bound: the plan is not empty but the paper's
    range width from the bound, as a hand-set range there, and nothing is reported
    beyond the bound."""
    scene = synthetic.textured_layers((5, 5, 128, 128), (-3.0, 0.2, 2.5), seed=0)
    d = liff.LiFF.create(**bounds)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", liff.SlopeRangeWarning)
        slopes = liff.keypoint_slopes(d.detect(scene.light_field))
    searched = d.getSearchedSlopes()
    assert len(slopes) > 0 and len(searched) >= 3
    if "firstSlope" in bounds:
        assert searched[0] == pytest.approx(2.6) and searched[-1] == pytest.approx(4.6)
        assert slopes.min() >= 2.6 - 1e-4
    else:
        assert searched[-1] == pytest.approx(-5.0) and searched[0] == pytest.approx(-7.0)
        assert slopes.max() <= -5.0 + 1e-4


def test_dark_outer_views_leave_the_sweep_the_inner_ones():
    """Alpha 0 on the outer ring of 5x5 views (a lenslet capture's vignetted corners and
    edges): the sweep compares the outermost usable views instead, and the layers at
    -4.8 and +5.6 are still found as with a hand-set range."""
    scene = synthetic.textured_layers((5, 5, 128, 128), (-4.8, 0.0, 5.6), seed=0)
    alpha = np.zeros((5, 5, 128, 128), np.float32)
    alpha[1:4, 1:4] = 1
    lf = np.stack([scene.light_field.astype(np.float32), alpha], axis=-1)
    slopes = liff.keypoint_slopes(liff.LiFF.create().detect(lf))
    for layer in (-4.8, 0.0, 5.6):
        assert np.sum(np.abs(slopes - layer) <= 0.1) >= 20, layer


def test_a_survey_that_finds_nothing_in_a_light_field_with_content_warns():
    """Alpha 0 on every other row (each survey patch half invalid): the survey finds
    no structure and the paper's [-1, 1] is searched; that is said, not silent. A
    constant light field (nothing to find) and an ordinary one do not warn."""
    scene = synthetic.textured_layers((5, 5, 128, 128), (-5.6, 0.0, 6.4), seed=0)
    lf = scene.light_field.astype(np.float32)
    alpha = np.ones(lf.shape, np.float32)
    alpha[..., ::2, :] = 0
    with pytest.warns(liff.SlopeRangeWarning, match=r"survey found no structure.*\[-1, 1\]"):
        liff.LiFF.create().detect(np.stack([lf, alpha], axis=-1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        liff.LiFF.create().detect(np.full((5, 5, 128, 128), 0.3, np.float32))
        liff.LiFF.create().detect(lf)
