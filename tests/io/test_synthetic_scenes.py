"""liff.synthetic: the scene generators the other tests rely on render what they claim."""

import itertools

import numpy as np
import pytest

from liff import synthetic
from liff.synthetic import Blob


def centroid(img):
    w = np.abs(img)
    yy, xx = np.mgrid[0:img.shape[0], 0:img.shape[1]]
    return (w * xx).sum() / w.sum(), (w * yy).sum() / w.sum()


@pytest.mark.parametrize("shape", [(5, 5, 48, 64), (4, 6, 48, 48), (1, 7, 40, 40), (3, 1, 40, 40)])
@pytest.mark.parametrize("profile", ["gaussian", "disk"])
def test_blob_moves_by_slope_per_view(shape, profile):
    T, S, V, U = shape
    blob = Blob(x=20.3, y=21.6, radius=3.0, slope=0.7, intensity=0.3)
    lf = synthetic.render_disks([blob], shape, background=0.25, profile=profile)
    assert lf.shape == shape and lf.dtype == np.float64
    for t, s in itertools.product(range(T), range(S)):
        cx, cy = centroid(lf[t, s] - 0.25)
        ex = blob.x - blob.slope * (s - (S - 1) / 2)
        ey = blob.y - blob.slope * (t - (T - 1) / 2)
        assert (cx, cy) == pytest.approx((ex, ey), abs=0.02), (t, s)


def test_gaussian_profile_values():
    blob = Blob(x=10, y=12, radius=2.0, slope=0.0, intensity=-0.4)
    lf = synthetic.render_disks([blob], (1, 1, 32, 32), background=0.5, profile="gaussian")
    assert lf[0, 0, 12, 10] == pytest.approx(0.1)
    assert lf[0, 0, 12, 12] == pytest.approx(0.5 - 0.4 * np.exp(-4 / 8))
    assert lf[0, 0, 30, 30] == 0.5
    assert (lf[0, 0] - 0.5).sum() == pytest.approx(-0.4 * 2 * np.pi * 4, rel=1e-3)


def test_disk_profile_values_and_area():
    blob = Blob(x=16.25, y=15.5, radius=5.0, slope=0.0, intensity=0.2)
    lf = synthetic.render_disks([blob], (1, 1, 32, 32), background=0.3)[0, 0]
    assert lf.max() == pytest.approx(0.5) and lf.min() == pytest.approx(0.3)
    # anti-aliased edge: a linear ramp from r - 0.5 to r + 0.5, so the area is pi r^2
    assert ((lf - 0.3) / 0.2).sum() == pytest.approx(np.pi * 5.0**2, rel=0.01)


def test_nearer_disk_occludes_regardless_of_order():
    far = Blob(x=16, y=16, radius=6, slope=-0.5, intensity=0.4)
    near = Blob(x=16, y=16, radius=3, slope=0.5, intensity=-0.4)
    shape = (3, 3, 32, 32)
    a = synthetic.render_disks([far, near], shape)
    b = synthetic.render_disks([near, far], shape)
    np.testing.assert_array_equal(a, b)
    assert a[1, 1, 16, 16] == pytest.approx(0.1)  # the near (dark) disk is in front
    assert a[1, 1, 16, 21] == pytest.approx(0.9)  # the far one shows around it


def test_noise_variance_and_seed():
    shape = (3, 3, 64, 64)
    clean = synthetic.render_disks([], shape, background=0.5)
    np.testing.assert_array_equal(clean, 0.5)
    noisy = synthetic.render_disks([], shape, background=0.5, noise_variance=0.01, seed=4)
    assert np.var(noisy - clean) == pytest.approx(0.01, rel=0.05)
    assert abs(np.mean(noisy - clean)) < 0.005
    again = synthetic.render_disks([], shape, background=0.5, noise_variance=0.01, seed=4)
    other = synthetic.render_disks([], shape, background=0.5, noise_variance=0.01, seed=5)
    np.testing.assert_array_equal(noisy, again)
    assert not np.array_equal(noisy, other)


def test_blob_is_frozen_dataclass():
    b = Blob(1, 2, 3, 0.5, 0.1)
    with pytest.raises(Exception):
        b.x = 5
    assert b == Blob(1, 2, 3, 0.5, 0.1)


@pytest.mark.parametrize("shape", [(9, 9, 256, 256), (7, 7, 128, 128), (5, 5, 96, 160)])
@pytest.mark.parametrize("n", [12, 26])
def test_paper_disks_layout(shape, n):
    T, S, V, U = shape
    disks = synthetic.paper_disks(n=n, shape=shape, contrast=0.1, slope_range=(-1, 1), seed=3)
    assert len(disks) == n
    np.testing.assert_allclose(sorted(d.slope for d in disks), np.linspace(-1, 1, n))
    assert all(d.intensity == 0.1 for d in disks)
    assert all(2.5 - 1e-9 <= d.radius <= 8 + 1e-9 for d in disks)
    # no two disks overlap in any view (checked in the four corner views and centre)
    for t, s in [(0, 0), (0, S - 1), (T - 1, 0), (T - 1, S - 1), ((T - 1) / 2, (S - 1) / 2)]:
        pos = [(d.x - d.slope * (s - (S - 1) / 2), d.y - d.slope * (t - (T - 1) / 2)) for d in disks]
        for i, j in itertools.combinations(range(n), 2):
            gap = np.hypot(pos[i][0] - pos[j][0], pos[i][1] - pos[j][1])
            assert gap > disks[i].radius + disks[j].radius, (i, j, t, s)
        for (x, y), d in zip(pos, disks):
            assert d.radius <= x <= U - d.radius and d.radius <= y <= V - d.radius


def test_paper_disks_seeded():
    a = synthetic.paper_disks(seed=1)
    assert a == synthetic.paper_disks(seed=1)
    assert a != synthetic.paper_disks(seed=2)
    assert len(a) == 26


@pytest.mark.parametrize("seed", [0, 1, 7])
def test_random_blob_layers_properties(seed):
    slopes = [-0.8, -0.3, 0.2, 0.7]
    shape = (7, 7, 128, 128)
    blobs = synthetic.random_blob_layers(slopes, shape, blobs_per_layer=12,
                                         radius_range=(2.0, 4.0), seed=seed, margin=10)
    assert len(blobs) == 48
    assert sorted({b.slope for b in blobs}) == slopes
    assert all(sum(b.slope == s for b in blobs) == 12 for s in slopes)
    for b in blobs:
        assert 2.0 <= b.radius <= 4.0
        assert 0.3 <= abs(b.intensity) <= 0.5
        assert 10 <= b.x <= 118 and 10 <= b.y <= 118
    assert {np.sign(b.intensity) for b in blobs} == {-1.0, 1.0}
    for a, b in itertools.combinations(blobs, 2):
        assert np.hypot(a.x - b.x, a.y - b.y) >= 4 * max(a.radius, b.radius) - 1e-9
    assert blobs == synthetic.random_blob_layers(slopes, shape, seed=seed)


def test_random_blob_layers_gives_up_when_full():
    # asking for far more blobs than fit returns as many as fit, without hanging
    blobs = synthetic.random_blob_layers([0.0], (3, 3, 40, 40), blobs_per_layer=500, seed=0)
    assert 0 < len(blobs) < 500


def test_textured_layers_follow_their_slopes():
    """Away from occlusion edges, view (t, s) is the centre view shifted by the slope."""
    shape = (5, 5, 96, 128)
    scene = synthetic.textured_layers(shape, slopes=(-1.0, 0.0, 1.0), noise_variance=0)
    lf, slopes = scene.light_field, scene.slope_map
    assert lf.shape == shape and lf.dtype == np.float32 and slopes.shape == (96, 128)
    assert set(np.unique(slopes)) == {-1.0, 0.0, 1.0}
    centre = lf[2, 2]
    # Slope 1 (bars) and -1 (background) move by whole pixels: view (2, 3) at (x, y)
    # equals the centre at (x + slope, y) for pixels inside a layer, away from its edges.
    # (pixels whose row neighbours within 3 px are on the same layer: nothing nearer
    # can cover them in view (2, 3), and the bilinear warp reads only their layer.)
    inner = np.ones(slopes.shape, bool)
    for k in range(-3, 4):
        inner &= np.roll(slopes, k, axis=1) == slopes
    for slope in (-1, 1):
        ys, xs = np.nonzero(inner[4:-4, 4:-4] & (slopes[4:-4, 4:-4] == slope))
        ys, xs = ys + 4, xs + 4
        np.testing.assert_allclose(lf[2, 3][ys, xs - slope], centre[ys, xs], atol=1e-5)


def test_textured_layers_contrast_and_noise():
    clean = synthetic.textured_layers((3, 3, 64, 64), noise_variance=0, contrast=0.1)
    noisy = synthetic.textured_layers((3, 3, 64, 64), noise_variance=1e-3, contrast=0.1)
    assert clean.light_field.std() < 0.05  # a tenth of the full-contrast texture
    assert abs((noisy.light_field - clean.light_field).var() - 1e-3) < 2e-4
    with pytest.raises(ValueError, match="three increasing"):
        synthetic.textured_layers(slopes=(0.5, 0.1, 0.7))


@pytest.mark.parametrize("shape", [(0, 0, 32, 32), (3, 3, 0, 32), (3, 3, 32, -1), (3, 3, 32),
                                   (3, 3, 32.5, 32), (3, 3, 32, 32, 1)])
def test_generators_refuse_bad_shapes(shape):
    with pytest.raises(ValueError, match="shape"):
        synthetic.render_disks([], shape)
    with pytest.raises(ValueError, match="shape"):
        synthetic.paper_disks(shape=shape)
    with pytest.raises(ValueError, match="shape"):
        synthetic.textured_layers(shape)


@pytest.mark.parametrize("variance", [-1.0, -1e-9, float("nan"), float("inf")])
def test_generators_refuse_bad_noise(variance):
    with pytest.raises(ValueError, match="noise_variance"):
        synthetic.render_disks([], (1, 1, 8, 8), noise_variance=variance)
    with pytest.raises(ValueError, match="noise_variance"):
        synthetic.textured_layers((1, 1, 8, 8), noise_variance=variance)


def test_generators_take_the_smallest_shapes_and_check_the_rest():
    """One view of one pixel is a light field (the texture blur copes); numpy ints are
    sizes; an unknown profile and no disks are errors."""
    assert synthetic.render_disks([], (1, 1, 1, 1)).shape == (1, 1, 1, 1)
    assert synthetic.textured_layers((1, 1, 1, 1)).light_field.shape == (1, 1, 1, 1)
    shape = tuple(np.int64(n) for n in (3, 3, 16, 16))
    assert synthetic.textured_layers(shape, noise_variance=0).light_field.shape == (3, 3, 16, 16)
    assert len(synthetic.paper_disks(n=4, shape=shape)) == 4
    with pytest.raises(ValueError, match="profile"):
        synthetic.render_disks([], (1, 1, 8, 8), profile="square")
    with pytest.raises(ValueError, match="at least 1 disk"):
        synthetic.paper_disks(n=0)


def test_textured_plane_views_are_windows_onto_one_world():
    """View (t, s) shows centre-view content (x, y) at (x - m (s - s_c), y - m (t - t_c)),
    and beyond the centre view's frame the world goes on (no reflected border)."""
    from liff.synthetic import textured_plane

    lf = textured_plane((3, 3, 40, 50), 2.0, seed=4)
    assert lf.shape == (3, 3, 40, 50) and lf.dtype == np.float32
    assert 0 <= lf.min() and lf.max() <= 1
    centre = lf[1, 1]
    np.testing.assert_allclose(lf[1, 2][:, :-2], centre[:, 2:], atol=1e-6)  # s - s_c = 1
    np.testing.assert_allclose(lf[0, 1][2:, :], centre[:-2, :], atol=1e-6)  # t - t_c = -1
    # The columns that view (1, 2) shows beyond the centre view's right border are new
    # content, not the centre view's last columns mirrored.
    assert not np.allclose(lf[1, 2][:, -2:], centre[:, -2:][:, ::-1], atol=1e-3)
    with pytest.raises(ValueError, match="slope"):
        textured_plane((3, 3, 40, 50), float("nan"))
    with pytest.raises(ValueError):
        textured_plane((0, 3, 40, 50), 1.0)
