"""The automatic range on long rows of views and small isolated features ("No silent
wrong answers" item 3): a single row or column of many views (linear stages) and
blobs a few pixels across, which the survey's decimated levels do not see, are searched
at their slopes; where the views bound the range (docs/SLOPES.md, "Bound"), structure
beyond it is warned of."""
import warnings

import numpy as np
import pytest

import liff
from liff import synthetic

SLOPES = np.linspace(-0.8, 0.8, 8)


def _row_scene(shape, radius=3.0, slopes=SLOPES, dtype=np.float32):
    """Disks at `slopes`, each where every view sees it (a margin of its largest
    shift plus a few radii from each border), on a grid; light field in `dtype`."""
    T, S, V, U = shape
    shift_x = max(abs(m) for m in slopes) * (S - 1) / 2
    shift_y = max(abs(m) for m in slopes) * (T - 1) / 2
    mx, my = shift_x + 4 * radius + 6, shift_y + 4 * radius + 6
    cols = 4 if U - 2 * mx >= 3 * 6 * radius else 2
    rows = int(np.ceil(len(slopes) / cols))
    xs = np.linspace(mx, U - 1 - mx, cols)
    ys = np.linspace(my, V - 1 - my, rows) if rows > 1 else np.array([V / 2])
    assert np.min(np.diff(xs)) >= 4 * radius and (rows == 1 or np.min(np.diff(ys)) >= 4 * radius)
    blobs = [synthetic.Blob(float(xs[i % cols]) + 0.3, float(ys[i // cols]) + 0.6, radius,
                            float(m), 0.3) for i, m in enumerate(slopes)]
    lf = synthetic.render_disks(blobs, shape, noise_variance=1e-4, seed=1)
    if dtype == np.uint8:
        lf = np.clip(lf * 255 + 0.5, 0, 255).astype(np.uint8)
    return lf.astype(dtype, copy=False), blobs


def _found(detector, lf, blobs):
    with warnings.catch_warnings():
        warnings.simplefilter("error", liff.SlopeRangeWarning)  # none expected here
        keypoints = detector.detect(lf)
    return synthetic.match_blobs(keypoints, blobs, 2.0, 5.0).found


@pytest.mark.parametrize("shape", [(1, 17, 96, 128), (1, 25, 96, 128), (1, 51, 96, 128),
                                   (1, 51, 192, 256), (25, 1, 128, 96), (9, 9, 96, 128)])
@pytest.mark.parametrize("dtype", [np.float32, np.uint8])
def test_blobs_of_a_row_of_views_are_found_as_with_the_papers_range(shape, dtype):
    """Disks of radius 3 at -0.8..0.8, every view seeing each: the automatic range finds
    all 8, as [-1, 1] set by hand does (before: 1x51 views of 96x128 found 4, the reach
    being 0.48; 25x1 views of 128x96 1)."""
    lf, blobs = _row_scene(shape, dtype=dtype)
    automatic = _found(liff.LiFF.create(), lf, blobs)
    by_hand = _found(liff.LiFF.create(firstSlope=-1.0, lastSlope=1.0), lf, blobs)
    assert by_hand.sum() == len(blobs)
    assert automatic.sum() == len(blobs), np.round(SLOPES[~automatic], 2)


@pytest.mark.parametrize("shape", [(1, 17, 96, 128), (1, 25, 96, 128), (1, 51, 192, 256),
                                   (9, 9, 96, 128)])
def test_small_isolated_blobs_are_searched_beside_structure_the_survey_finds(shape):
    """The paper's disk scene (liff.synthetic.paper_disks: radius 2.5, contrast 0.3,
    slopes -0.8..0.8) on rows of views: the decimated levels do not see disks this
    small, so their slopes come from the plane sweep, whose votes gather at each disk
    (docs/SLOPES.md item 4). Every disk that every view sees at its slope and that [-1, 1]
    set by hand finds is found (before: 1x25 views found 1 of 8, 1x17 4, 1x51 of
    192x256 3, 9x9 7, silently)."""
    T, S, V, U = shape
    blobs = synthetic.paper_disks(n=8, shape=shape, slope_range=(-0.8, 0.8), seed=0,
                                  contrast=0.3)
    lf = synthetic.render_disks(blobs, shape, noise_variance=1e-4, seed=1).astype(np.float32)
    automatic = _found(liff.LiFF.create(), lf, blobs)
    by_hand = _found(liff.LiFF.create(firstSlope=-1.0, lastSlope=1.0), lf, blobs)
    seen = np.array([b.radius <= b.x - abs(b.slope) * (S - 1) / 2 and
                     b.x + abs(b.slope) * (S - 1) / 2 <= U - 1 - b.radius and
                     b.radius <= b.y - abs(b.slope) * (T - 1) / 2 and
                     b.y + abs(b.slope) * (T - 1) / 2 <= V - 1 - b.radius for b in blobs])
    assert (by_hand & seen).sum() >= 6
    assert not (by_hand & seen & ~automatic).any(), [b.slope for b, f in
                                                    zip(blobs, by_hand & seen & ~automatic) if f]


@pytest.mark.parametrize("shape, reach", [
    ((1, 51, 96, 128), 1.0),        # a quarter of 128 over 50 steps is 0.64: up to half
    ((51, 1, 128, 96), 1.0),        # a column: its views' height counts
    ((1, 51, 400, 401), 400 / 200),  # a quarter of the shorter side beyond 1: as before
    ((1, 9, 64, 512), 64 / 32),     # a wide strip: as before (not its long side's 16)
    ((1, 101, 96, 128), 128 / 200),  # half the view along the row is under 1
    ((9, 9, 96, 128), 96 / 32),     # a grid: the shorter side, as before
    ((5, 9, 100, 100), 100 / 32),   # the axis with more views bounds it
])
def test_the_automatic_reach_counts_the_axes_with_parallax(shape, reach):
    lf, _ = _row_scene(shape, slopes=[0.0, 0.2])
    d = liff.LiFF.create()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", liff.SlopeRangeWarning)  # (not what is tested)
        d.detect(lf)
    assert d.getSlopeRangeReport().automaticReach == pytest.approx(reach)


@pytest.mark.parametrize("beyond", [-2.15, 2.6, -3.0])
def test_structure_beyond_the_reach_is_warned_of(beyond):
    """9x9 views of 64x64: R = 2; a disk at -2.15 to -3 lies beyond it. Where R is small
    (under SMALL_REACH) the sweep looks up to min(R, 1) further, sees it, and the call
    says so (before: silently missed; docs/SLOPES.md, "Bound")."""
    lf, blobs = _row_scene((9, 9, 64, 64), radius=2.0, slopes=[-0.5, 0.5, beyond])
    d = liff.LiFF.create()
    with pytest.warns(liff.SlopeRangeWarning, match=r"within \+-2\.00 .*set firstSlope"):
        d.detect(lf)
    assert d.getSlopeRangeReport().structureBeyondReach


def test_structure_within_the_reach_is_not_warned_of():
    lf, blobs = _row_scene((9, 9, 64, 64), radius=2.0, slopes=[-1.5, -0.5, 0.5, 1.5])
    d = liff.LiFF.create()
    with warnings.catch_warnings():
        warnings.simplefilter("error", liff.SlopeRangeWarning)
        d.detect(lf)
    assert not d.getSlopeRangeReport().structureBeyondReach


@pytest.mark.parametrize("shape, slope", [((9, 9, 96, 128), 0.0), ((9, 9, 96, 128), 0.3),
                                          ((1, 17, 96, 128), -0.6), ((17, 1, 96, 128), -0.6)])
def test_a_repeated_pattern_is_not_structure_beyond_the_reach(shape, slope):
    """A grid of dots 12 px apart: the sweep compares the reference with the outermost
    views only, which the grid matches again at alias slopes (12 px over the outermost
    offset), at or beyond R. The views of the reference's row and column disagree there,
    so no warning and no features at the aliases."""
    T, S, V, U = shape
    dots = [synthetic.Blob(x + 0.3, y + 0.6, 2.0, slope, 0.3)
            for x in range(12, U - 10, 12) for y in range(12, V - 10, 12)]
    lf = synthetic.render_disks(dots, shape, noise_variance=1e-4, seed=1).astype(np.float32)
    d = liff.LiFF.create()
    with warnings.catch_warnings():
        warnings.simplefilter("error", liff.SlopeRangeWarning)
        keypoints = d.detect(lf)
    assert not d.getSlopeRangeReport().structureBeyondReach
    assert np.mean(np.abs(liff.keypoint_slopes(keypoints) - slope) < 0.5) > 0.95


def test_evenly_spaced_small_disks_on_a_row_are_found_at_their_slopes():
    """Disks 16 px apart on a row of 1x9 views, slopes -0.8..0.8: the pattern's alias
    slopes (16 px / 4 views) gave clusters the views do not agree on (before the check:
    slices at 3.25-4.25, features at 3.4-3.7, 6 of 8 disks, a warning of structure beyond
    R)."""
    blobs = [synthetic.Blob(15.5 + 16.1 * i, 12.6, 2.0, float(m), 0.3)
             for i, m in enumerate(np.linspace(-0.8, 0.8, 8)[:7])]
    blobs.append(synthetic.Blob(15.5, 83.6, 2.0, 0.8, 0.3))
    lf = synthetic.render_disks(blobs, (1, 9, 96, 128), noise_variance=1e-4,
                                seed=1).astype(np.float32)
    d = liff.LiFF.create()
    found = _found(d, lf, blobs)
    assert found.all()
    assert max(abs(m) for m in d.getSlopeRangeReport().slicesUsed) <= 1.5


@pytest.mark.parametrize("slope", [4.5, 5.0])
def test_a_plane_just_beyond_the_reach_of_a_strip_is_warned_of(slope):
    """1x9 views of 128x256: R = 4 (a quarter of the shorter side over 8 steps). A plane
    at 4.5 or 5 gave 54-90 features at wrong slopes and no warning; the sweep now looks
    up to min(R, 1) beyond R and says so."""
    lf = synthetic.textured_plane((1, 9, 128, 256), slope, seed=1)
    d = liff.LiFF.create()
    with pytest.warns(liff.SlopeRangeWarning, match=r"within \+-4\.00 .*wrong slopes"):
        d.detect(lf)
    assert d.getSlopeRangeReport().structureBeyondReach


@pytest.mark.parametrize("bounds, slope", [(dict(firstSlope=0.0), 4.5),
                                           (dict(lastSlope=0.0), -4.6)])
def test_a_half_automatic_range_warns_of_structure_beyond_its_automatic_end(bounds, slope):
    """The automatic end of a half-automatic range is bounded by R as well: structure
    beyond it warns (before: the report said so but no warning came, and 90 features
    at wrong slopes were returned silently)."""
    lf = synthetic.textured_plane((1, 9, 128, 256), slope, seed=1)
    d = liff.LiFF.create(**bounds)
    with pytest.warns(liff.SlopeRangeWarning, match=r"within \+-4\.00"):
        d.detect(lf)
    report = d.getSlopeRangeReport()
    assert report.structureBeyondReach and report.automaticReach == pytest.approx(4.0)
