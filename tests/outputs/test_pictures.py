"""Pictures that can be checked by eye: the demo's picture marks found and missed blobs
and shows each feature's slope colour, the colour bar's labels are legible at any size,
and the features_3d sample's axis labels are not hidden (moved from the command line's
usage tests)."""

from __future__ import annotations

import importlib.util
import os

import cv2
import numpy as np
import pytest

import liff
from liff.cli import main

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def test_demo_picture_marks_found_and_missed_blobs(tmp_path):
    from liff.plot import dot_radius, draw_ground_truth, draw_keypoints_by_slope

    picture = draw_keypoints_by_slope(np.full((100, 100), 0.5), [], (-1, 1))
    points, found = np.array([[20, 30], [70, 40], [50, 80]]), np.array([True, False, True])
    draw_ground_truth(picture, points, found)
    gap = dot_radius(2) + 2
    for (x, y), hit in zip(points, found):
        if hit:  # a white + whose middle is left open for the feature's dot
            assert tuple(picture[2 * y, 2 * x + gap + 1]) == (255, 255, 255)
            assert tuple(picture[2 * y, 2 * x]) == (128, 128, 128)
        else:
            assert tuple(picture[2 * y, 2 * x]) == (255, 0, 255)
    magenta_rows = np.where((picture == (255, 0, 255)).all(axis=2).any(axis=1))[0]
    assert magenta_rows.min() < picture.shape[0] / 4  # the legend "x missed 1", at the top


def test_the_demo_picture_shows_each_features_slope_colour(tmp_path):
    """Issue 29: the white + of a found blob covered its feature's slope colour. In the
    picture `liff demo` writes, the pixel at every feature's centre has the slope colour
    of a feature there (its own, or one drawn later within the dot's radius)."""
    from liff.demo import demo_light_field
    from liff.plot import dot_radius, slope_colours

    assert main(["demo", "--out", str(tmp_path)]) == 0
    picture = cv2.imread(str(tmp_path / "features.png"))
    detector = liff.LiFF.create()
    keypoints, _ = detector.detectAndCompute(demo_light_field()[0])  # what the demo drew
    used = detector.getSlicesUsed()
    colours = slope_colours(liff.keypoint_slopes(keypoints), (used[0], used[-1]))
    centres = np.round(np.array([kp.pt for kp in keypoints]) * 2 + 0.5).astype(int)  # scale 2
    assert len(keypoints) > 100
    for centre in centres:
        near = np.abs(centres - centre).max(axis=1) <= dot_radius(2)
        pixel = picture[centre[1], centre[0]]
        assert (colours[near] == pixel).all(axis=1).any(), (centre, pixel)


@pytest.mark.parametrize("size", [8, 60, 192, 600, 3000])
def test_colour_bar_labels_are_legible_at_any_size(size):
    """The bar's labels are at least 9 px high, at most 5% of the picture (or 12 px),
    and not cut off."""
    from liff.plot import draw_keypoints_by_slope, text_scale

    picture = draw_keypoints_by_slope(np.zeros((size, size)), [], (-1, 1), scale=1)
    height = picture.shape[0]
    (_, text_height), _ = cv2.getTextSize("+1.00", cv2.FONT_HERSHEY_SIMPLEX, text_scale(height), 1)
    assert 9 <= text_height <= max(12, 0.05 * height)
    bar = picture[:, size:]
    assert (bar[:, -2:] == 255).all() and (bar[:2] == 255).all() and (bar[-2:] == 255).all()
    assert (bar < 100).all(axis=2).sum() > 20 * text_height  # the text is there


def test_features_3d_axis_labels_are_not_hidden():
    import matplotlib

    matplotlib.use("Agg")
    spec = importlib.util.spec_from_file_location("features_3d", os.path.join(ROOT, "samples", "features_3d.py"))
    sample = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(sample)
    rng = np.random.default_rng(0)
    figure = sample.plot_features(rng.uniform(0, 500, (50, 2)), rng.uniform(-2, 2, 50), (-2, 2), "t")
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    axes, colour_bar = figure.axes
    labels = [a.label for a in (axes.xaxis, axes.yaxis, axes.zaxis)]
    ticks = [t for a in (axes.xaxis, axes.yaxis, axes.zaxis) for t in a.get_ticklabels() if t.get_text()]
    for label in labels:
        box = label.get_window_extent(renderer)
        assert not box.overlaps(colour_bar.get_tightbbox(renderer)), label.get_text()
        assert not any(box.overlaps(t.get_window_extent(renderer)) for t in ticks), label.get_text()

