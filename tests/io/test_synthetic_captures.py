"""liff.captures: synthetic multi-view light-field captures with ground truth."""

import numpy as np
import pytest

import liff
from liff import captures

SMALL = dict(n_poses=2, views=(3, 3), size=(48, 64), focal=60.0, supersample=1)


@pytest.fixture(scope="module")
def small():
    return captures.make_capture(seed=3, **SMALL)


def dot_patch(centre, axis_u, axis_v, n=512, sigma_texels=10.0):
    """A dark (0.2) square with one bright Gaussian dot at its centre."""
    yy, xx = np.mgrid[0:n, 0:n] - (n - 1) / 2
    texture = 0.2 + 0.7 * np.exp(-(xx**2 + yy**2) / (2 * sigma_texels**2))
    return captures.Patch(np.asarray(centre, float), np.asarray(axis_u, float),
                          np.asarray(axis_v, float), texture.astype(np.float32))


def dot_centroid(image):
    """Centre (x, y) of the brightness above the square's 0.2 (the square must fill the
    view: rendering is linear, so this is the dot's centre without threshold bias)."""
    weight = image - 0.2
    assert weight.min() > -1e-4, "the square does not fill the view"
    rows, cols = np.mgrid[0:image.shape[0], 0:image.shape[1]]
    return (weight * cols).sum() / weight.sum(), (weight * rows).sum() / weight.sum()


def test_shapes_and_dtypes(small):
    assert len(small.light_fields) == len(small.poses) == 2
    for lf in small.light_fields:
        assert lf.shape == (3, 3, 48, 64) and lf.dtype == np.float32
        assert np.isfinite(lf).all() and 0 <= lf.min() and lf.max() <= 1
        assert lf.std() > 0.03  # textured, not blank
    for pose in small.poses:
        assert np.allclose(pose.rotation @ pose.rotation.T, np.eye(3), atol=1e-12)
        assert np.isclose(np.linalg.det(pose.rotation), 1.0)
    k = small.intrinsics
    assert (k.width, k.height, k.cx, k.cy) == (64, 48, 31.5, 23.5)
    assert small.centre_views()[0].shape == (48, 64)


def test_deterministic_given_the_seed(small):
    again = captures.make_capture(seed=3, **SMALL)
    other = captures.make_capture(seed=4, **SMALL)
    for a, b in zip(small.light_fields, again.light_fields):
        assert np.array_equal(a, b)
    assert not np.allclose(small.light_fields[0], other.light_fields[0])
    noisy = [captures.degrade(small, 0.5, 1e-3, seed=9).light_fields[0] for _ in range(2)]
    assert np.array_equal(noisy[0], noisy[1])


@pytest.mark.parametrize("slope_range", [(-1.0, 1.0), (0.2, 1.5)])
@pytest.mark.parametrize("depth", [4.0, 6.0, 9.0])
def test_view_shift_follows_liffs_slope_convention(slope_range, depth):
    # Camera at the origin looking along +z; a dot straight ahead at the given depth.
    pose = captures.Pose(np.eye(3), np.zeros(3))
    half = 0.6 * depth  # fills the view: 48 px either side of the centre
    square = dot_patch((0, 0, depth), (half, 0, 0), (0, half, 0))
    cap = captures.make_capture(n_poses=1, views=(5, 5), size=(64, 64), focal=80.0, supersample=2,
                                slope_range=slope_range, patches=[square], poses=[pose])
    slope = float(cap.slope_at_depth(depth))
    lf = cap.light_fields[0]
    xc, yc = dot_centroid(lf[2, 2])
    assert abs(xc - 31.5) < 0.01 and abs(yc - 31.5) < 0.01
    for t in range(5):
        for s in range(5):
            x, y = dot_centroid(lf[t, s])
            # docs/CONVENTIONS.md: (x - slope*(s - s_c), y - slope*(t - t_c)).
            assert x == pytest.approx(xc - slope * (s - 2), abs=0.01)
            assert y == pytest.approx(yc - slope * (t - 2), abs=0.01)


def test_slope_range_sets_far_and_near_slopes():
    square = dot_patch((0, 0, 5), (1, 0, 0), (0, 1, 0))
    cap = captures.make_capture(n_poses=1, views=(1, 1), size=(16, 16), slope_range=(-1.0, 1.0),
                                patches=[square], poses=[captures.Pose(np.eye(3), np.zeros(3))])
    assert cap.slope_at_depth(8.7) == pytest.approx(-1.0)
    assert cap.slope_at_depth(3.6) == pytest.approx(1.0)
    assert cap.slope_at_depth(cap.focus_depth) == pytest.approx(0.0, abs=1e-12)
    assert cap.baseline == pytest.approx(2 / (1 / 3.6 - 1 / 8.7) / 300.0)


def test_depth_map_and_slope_range_are_the_scene_geometry():
    # A wall facing the camera at depth 6 filling the view: its depth everywhere, its
    # slope the range; a smaller panel in front at depth 4 adds the near end.
    pose = captures.Pose(np.eye(3), np.zeros(3))
    flat = np.full((16, 16), 0.5, np.float32)
    wall = captures.Patch(np.array([0, 0, 6.0]), np.array([9.0, 0, 0]), np.array([0, 9.0, 0]), flat)
    panel = captures.Patch(np.array([0, 0, 4.0]), np.array([0.5, 0, 0]), np.array([0, 0.5, 0]), flat)
    cap = captures.make_capture(n_poses=1, views=(3, 3), size=(40, 50), focal=50.0, supersample=1,
                                patches=[wall, panel], poses=[pose])
    depth = cap.depth_map(0)
    assert depth.shape == (40, 50) and depth.dtype == np.float32
    assert depth[0, 0] == pytest.approx(6.0) and depth[20, 25] == pytest.approx(4.0)
    assert cap.slope_range() == pytest.approx((cap.slope_at_depth(6.0), cap.slope_at_depth(4.0)))
    # nothing in view: inf depths and no range
    behind = captures.Patch(np.array([0, 0, -5.0]), panel.axis_u, panel.axis_v, flat)
    empty = captures.make_capture(n_poses=1, views=(1, 1), size=(16, 16), patches=[behind],
                                  poses=[pose])
    assert np.isinf(empty.depth_map(0)).all()
    with pytest.raises(ValueError, match="expected a capture of a scene"):
        empty.slope_range()
    for index in (1, -1, 0.5):
        with pytest.raises(ValueError, match=r"expected an integer in \[0, 1\)"):
            cap.depth_map(index)


def test_liff_measures_the_rendered_slope():
    # A textured wall at one depth: LiFF's keypoint slopes must come out at its slope.
    pose = captures.Pose(np.eye(3), np.zeros(3))
    rng = np.random.default_rng(0)
    wall = captures.Patch(np.array([0, 0, 6.0]), np.array([4.0, 0, 0]), np.array([0, 4.0, 0]),
                          captures.structured_texture(rng, 320, 320))
    cap = captures.make_capture(n_poses=1, views=(7, 7), size=(96, 96), focal=100.0, supersample=2,
                                patches=[wall], poses=[pose])
    expected = float(cap.slope_at_depth(6.0))
    assert abs(expected) > 0.1  # the test would not tell the sign apart at 0
    detector = liff.LiFF.create(contrastThreshold=0.02, firstSlope=-1, lastSlope=1, numSlopes=21)
    slopes = liff.keypoint_slopes(detector.detect(cap.light_fields[0]))
    assert len(slopes) > 10
    assert np.median(slopes) == pytest.approx(expected, abs=0.1)


def test_poses_and_intrinsics_are_the_ground_truth():
    # A dot placed at a world point renders where K [R | t] projects it, for a rotated pose.
    target = np.array([0.4, -0.3, 0.5])
    pose = captures.arc_poses(3, seed=1)[2]
    forward = pose.rotation[2]  # the camera's z axis in world coordinates
    patch = dot_patch(target, 8 * pose.rotation[0], 8 * pose.rotation[1])  # facing the camera
    cap = captures.make_capture(n_poses=1, views=(3, 3), size=(80, 100), focal=90.0, supersample=2,
                                patches=[patch], poses=[pose])
    assert forward @ (target - pose.centre) > 0
    projected = cap.intrinsics.matrix() @ (pose.rotation @ target + pose.translation)
    x, y = dot_centroid(cap.light_fields[0][1, 1])
    assert (x, y) == pytest.approx(tuple(projected[:2] / projected[2]), abs=0.05)


def test_occluders_are_visible_and_in_front():
    common = dict(n_poses=1, views=(3, 3), size=(60, 80), focal=75.0, supersample=1)
    clean = captures.make_capture(seed=1, **common)
    fenced = captures.make_capture(seed=1, occluders=True, **common)
    changed = np.abs(fenced.light_fields[0] - clean.light_fields[0]) > 0.05
    assert 0.1 < changed.mean() < 0.5
    # The bars are dark (about 0.15) where they cover the scene.
    assert np.median(fenced.light_fields[0][changed]) < 0.25
    # and nearer than everything else: they move most between views (largest slope).
    moved_fence = np.abs(fenced.light_fields[0][1, 0] - fenced.light_fields[0][1, 2]).mean()
    moved_clean = np.abs(clean.light_fields[0][1, 0] - clean.light_fields[0][1, 2]).mean()
    assert moved_fence > moved_clean


def test_noise_variance_is_as_requested(small):
    for variance in (1e-4, 1e-2):
        noisy = captures.degrade(small, noise_variance=variance, seed=2)
        difference = np.concatenate([(a - b).ravel() for a, b in zip(noisy.light_fields, small.light_fields)])
        assert difference.var() == pytest.approx(variance, rel=0.05)
        assert abs(difference.mean()) < 4 * np.sqrt(variance / difference.size)
    assert noisy.poses is small.poses and noisy.intrinsics == small.intrinsics


def test_low_contrast_scales_deviations_about_the_mean(small):
    low = captures.degrade(small, contrast=0.2)
    for a, b in zip(low.light_fields, small.light_fields):
        assert a.std() == pytest.approx(0.2 * b.std(), rel=1e-4)
        assert np.allclose(a - 0.5, 0.2 * (b - 0.5), atol=1e-6)


def test_bad_arguments_raise():
    with pytest.raises(ValueError, match="slope_range"):
        captures.make_capture(n_poses=1, views=(1, 1), size=(16, 16), slope_range=(1.0, -1.0))
    with pytest.raises(ValueError, match="n_poses"):
        captures.make_capture(n_poses=0)
    cap = captures.make_capture(n_poses=1, views=(1, 1), size=(16, 16), supersample=1)
    with pytest.raises(ValueError, match="contrast"):
        captures.degrade(cap, contrast=0)
    with pytest.raises(ValueError, match="noise_variance"):
        captures.degrade(cap, noise_variance=-1)
