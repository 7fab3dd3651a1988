"""liff.hloc: features and matches in hloc's HDF5 layout, read back as hloc's readers
read them (hloc/utils/io.py: get_keypoints, get_matches, find_pair)."""

import re

import cv2
import numpy as np
import pytest

import liff
from liff import synthetic
from liff.hloc import names_to_pair, write_features, write_matches

h5py = pytest.importorskip("h5py")


@pytest.fixture(scope="module")
def two_views():
    shape = (5, 5, 96, 128)
    disks = synthetic.paper_disks(n=10, shape=shape, seed=1)
    lf = synthetic.render_disks(disks, shape)
    detector = liff.LiFF.create()
    return lf, detector.detectAndCompute(lf, None)


def test_features_read_as_hloc_reads_them(tmp_path, two_views):
    lf, (keypoints, descriptors) = two_views
    path = tmp_path / "feats-liff.h5"
    write_features(path, "scene/centre.png", keypoints, descriptors, (lf.shape[3], lf.shape[2]))
    with h5py.File(path, "r") as f:
        group = f["scene/centre.png"]  # hloc: hfile[name]
        kp = group["keypoints"].__array__()
        assert kp.dtype == np.float32 and kp.shape == (len(keypoints), 2)
        np.testing.assert_allclose(kp, [k.pt for k in keypoints], atol=1e-4)  # pixel centres at 0
        desc = group["descriptors"].__array__()
        assert desc.dtype == np.float32 and desc.shape == (128, len(keypoints))  # D x N
        np.testing.assert_array_equal(desc.T, descriptors)
        assert list(group["image_size"][()]) == [128, 96]  # (width, height)
        np.testing.assert_allclose(group["scores"][()], [k.response for k in keypoints], rtol=1e-6)
        np.testing.assert_allclose(group["scales"][()], [k.size / 2 for k in keypoints], rtol=1e-6)
        np.testing.assert_allclose(group["slopes"][()], liff.keypoint_slopes(keypoints), atol=1e-6)
        assert group["oris"].shape == (len(keypoints),)


def test_matches_read_as_hloc_reads_them(tmp_path, two_views):
    _, (keypoints, descriptors) = two_views
    matches = cv2.BFMatcher(cv2.NORM_L2, crossCheck=True).match(descriptors, descriptors)
    path = tmp_path / "matches.h5"
    write_matches(path, "a/0.png", "a/1.png", matches, len(keypoints), len(keypoints))
    with h5py.File(path, "r") as f:
        pair = names_to_pair("a/0.png", "a/1.png")
        assert pair == "a-0.png/a-1.png" and pair in f  # hloc's find_pair
        matches0 = f[pair]["matches0"].__array__()
        scores0 = f[pair]["matching_scores0"].__array__()
    assert matches0.shape == (len(keypoints),) and scores0.dtype == np.float32
    # hloc's get_matches: the pairs (i, matches0[i]) where matches0[i] != -1
    idx = np.where(matches0 != -1)[0]
    assert len(idx) == len(matches)
    assert all(matches0[m.queryIdx] == m.trainIdx for m in matches)
    assert np.all(scores0[idx] > 0) and np.all(scores0[matches0 == -1] == 0)


def test_clear_errors(tmp_path, two_views):
    lf, (keypoints, descriptors) = two_views
    path = tmp_path / "f.h5"
    write_features(path, "x.png", keypoints, descriptors, (128, 96))
    with pytest.raises(ValueError, match="already holds features of"):
        write_features(path, "x.png", keypoints, descriptors, (128, 96))
    write_features(path, "x.png", keypoints, descriptors, (128, 96), overwrite=True)
    with pytest.raises(ValueError, match="expected a relative path"):
        write_features(path, "/abs.png", keypoints, descriptors, (128, 96))
    with pytest.raises(ValueError, match="one row per keypoint"):
        write_features(path, "y.png", keypoints, descriptors[:-1], (128, 96))
    twice = [cv2.DMatch(0, 1, 0.5), cv2.DMatch(0, 2, 0.7)]
    with pytest.raises(ValueError, match="matched twice"):
        write_matches(tmp_path / "m.h5", "a.png", "b.png", twice, 3, 3)
    with pytest.raises(ValueError, match="queryIdx 5"):
        write_matches(tmp_path / "m.h5", "a.png", "b.png", [cv2.DMatch(5, 0, 0.1)], 3, 3)


# --- the command line: liff detect --hloc, liff match --hloc -----------------------------

def hloc_get_keypoints(path, name):
    """hloc/utils/io.py's get_keypoints."""
    with h5py.File(str(path), "r", libver="latest") as hfile:
        return hfile[name]["keypoints"].__array__()


def hloc_get_matches(path, name0, name1):
    """hloc/utils/io.py's get_matches (find_pair without the reversed lookup): (K, 2)
    index pairs and their scores."""
    with h5py.File(str(path), "r", libver="latest") as hfile:
        pair = names_to_pair(name0, name1)
        matches = hfile[pair]["matches0"].__array__()
        scores = hfile[pair]["matching_scores0"].__array__()
    idx = np.where(matches != -1)[0]
    return np.stack([idx, matches[idx]], -1), scores[idx]


def test_the_command_line_writes_hloc_files(tmp_path, capsys):
    from liff.cli import main
    from liff.feature_file import load_features

    for i in range(2):
        assert main(["synth", "disks", "--out", str(tmp_path / "lf" / f"scene{i}.npz"), "--views", "5",
                     "--size", "96", "128", "--seed", str(i)]) == 0
    feats, images = tmp_path / "hloc" / "feats-liff.h5", tmp_path / "hloc" / "images"
    assert main(["detect", str(tmp_path / "lf"), "--out", str(tmp_path / "feats"), "--hloc", str(feats),
                 "--hloc-images", str(images)]) == 0
    assert "hloc: 2 light field(s)" in capsys.readouterr().out
    found = [load_features(tmp_path / "feats" / f"scene{i}.npz") for i in range(2)]
    for i, features in enumerate(found):
        name = f"scene{i}.png"
        kp = hloc_get_keypoints(feats, name)
        np.testing.assert_allclose(kp, [k.pt for k in features.keypoints], atol=1e-4)
        image = cv2.imread(str(images / name), cv2.IMREAD_UNCHANGED)
        assert image.dtype == np.uint8 and image.ndim == 2  # grey 8-bit, as COLMAP reads it
        with h5py.File(feats, "r") as f:
            assert list(f[name]["image_size"][()]) == [image.shape[1], image.shape[0]]
            assert f[name]["descriptors"].shape == (128, len(features.keypoints))
    matches_file = tmp_path / "hloc" / "matches-liff.h5"
    assert main(["match", str(tmp_path / "feats" / "scene0.npz"), str(tmp_path / "feats" / "scene1.npz"),
                 "--hloc", str(matches_file), "--hloc-features", str(feats)]) == 0
    count = int(re.search(r"hloc: (\d+) matches of scene0.png and scene1.png", capsys.readouterr().out)[1])
    pairs, scores = hloc_get_matches(matches_file, "scene0.png", "scene1.png")
    assert len(pairs) == count and np.all(scores > 0)
    assert pairs[:, 1].max() < len(found[1].keypoints)
    # a re-run adds to the files: the features of a light field are replaced, not repeated
    assert main(["detect", str(tmp_path / "lf" / "scene0.npz"), "--out", str(tmp_path / "feats" / "scene0.npz"),
                 "--hloc", str(feats)]) == 0
    with h5py.File(feats, "r") as f:
        assert sorted(f) == ["scene0.png", "scene1.png"]


def test_the_command_line_refuses_a_foreign_hloc_file(tmp_path, capsys):
    from liff.cli import main

    lf = tmp_path / "scene.npz"
    assert main(["synth", "disks", "--out", str(lf), "--views", "3", "--size", "48", "48"]) == 0
    (tmp_path / "notes.h5").write_text("not hdf5")
    assert main(["detect", str(lf), "--out", str(tmp_path / "f.npz"), "--hloc", str(tmp_path / "notes.h5")]) == 1
    assert "is not an HDF5 file" in capsys.readouterr().err and not (tmp_path / "f.npz").exists()
    assert main(["detect", str(lf), "--out", str(tmp_path / "f.npz"), "--hloc", str(lf)]) == 1
    assert "--hloc" in capsys.readouterr().err
    assert main(["detect", str(lf), "--out", str(tmp_path / "f.npz"), "--hloc-images", str(tmp_path)]) == 1
    assert "--hloc-images without --hloc" in capsys.readouterr().err


def test_other_features_of_a_name_are_replaced_only_with_overwrite(tmp_path, capsys):
    """Matches index keypoints: replacing an image's features silently would leave the
    match files made from them stale (issue 29)."""
    from liff.cli import main

    for folder, seed in (("lf", 0), ("lf", 1), ("lf", 2), ("other", 7)):  # other/scene0: another capture
        name = f"scene{seed}" if folder == "lf" else "scene0"
        assert main(["synth", "disks", "--out", str(tmp_path / folder / f"{name}.npz"), "--views", "5",
                     "--size", "96", "128", "--seed", str(seed)]) == 0
    feats, matches = tmp_path / "feats-liff.h5", tmp_path / "matches-liff.h5"
    assert main(["detect", str(tmp_path / "lf"), "--out", str(tmp_path / "feats"), "--hloc", str(feats)]) == 0
    a, b, c = (str(tmp_path / "feats" / f"scene{i}.npz") for i in range(3))
    assert main(["match", a, b, "--hloc", str(matches), "--hloc-features", str(feats)]) == 0
    assert main(["match", a, c, "--hloc", str(matches), "--hloc-features", str(feats)]) == 0
    before = hloc_get_keypoints(feats, "scene0.png")
    capsys.readouterr()
    other = str(tmp_path / "other-feats" / "scene0.npz")
    assert main(["detect", str(tmp_path / "other" / "scene0.npz"), "--out", other, "--hloc", str(feats)]) == 1
    error = capsys.readouterr().err
    assert "other features of scene0.png" in error and "--overwrite" in error
    np.testing.assert_array_equal(hloc_get_keypoints(feats, "scene0.png"), before)  # untouched
    # the same features again are no change
    assert main(["detect", str(tmp_path / "lf" / "scene0.npz"), "--out", a, "--hloc", str(feats)]) == 0
    assert "replaced" not in capsys.readouterr().err
    assert main(["detect", str(tmp_path / "other" / "scene0.npz"), "--out", other, "--hloc", str(feats),
                 "--overwrite"]) == 0
    assert "replaced the features of scene0.png" in capsys.readouterr().err
    assert hloc_get_keypoints(feats, "scene0.png").shape != before.shape or not np.array_equal(
        hloc_get_keypoints(feats, "scene0.png"), before)
    # the old match file indexes the old keypoints: adding to it is refused, naming the
    # pair left stale (the pair matched again would replace its own group)
    assert main(["match", other, b, "--hloc", str(matches), "--hloc-features", str(feats)]) == 1
    error = capsys.readouterr().err
    assert "scene0.png/scene2.png (scene0.png changed)" in error and "stale" in error
    assert "scene0.png/scene1.png" not in error
    assert main(["match", other, b, "--hloc", str(tmp_path / "matches-new.h5"), "--hloc-features", str(feats)]) == 0
    pairs, _ = hloc_get_matches(tmp_path / "matches-new.h5", "scene0.png", "scene1.png")
    assert pairs[:, 0].max() < len(hloc_get_keypoints(feats, "scene0.png"))


def test_digests_tie_matches_to_the_features(tmp_path, two_views):
    from liff.hloc import DIGEST_ATTR, features_digest

    lf, (keypoints, descriptors) = two_views
    feats, path = tmp_path / "f.h5", tmp_path / "m.h5"
    d0 = write_features(feats, "a.png", keypoints, descriptors, (128, 96))
    d1 = write_features(feats, "b.png", keypoints[:-1], descriptors[:-1], (128, 96))
    assert d0 != d1 and features_digest(feats, "a.png") == d0
    with h5py.File(feats, "r") as f:
        assert f["a.png"].attrs[DIGEST_ATTR] == d0 and sorted(f["a.png"]) == [
            "descriptors", "image_size", "keypoints", "oris", "scales", "scores", "slopes"]
    write_matches(path, "a.png", "b.png", [cv2.DMatch(0, 1, 0.5)], len(keypoints), len(keypoints) - 1,
                  digests=(d0, d1))
    write_matches(path, "a.png", "c.png", [cv2.DMatch(0, 1, 0.5)], len(keypoints), 2, digests=(d0, "x"))
    d0_new = write_features(feats, "a.png", keypoints[:-2], descriptors[:-2], (128, 96), overwrite=True)
    with pytest.raises(ValueError, match=r"a\.png/b\.png \(a\.png changed\), a\.png/c\.png \(a\.png changed\)"):
        write_matches(path, "a.png", "d.png", [], len(keypoints) - 2, 0, digests=(d0_new, "y"))
    # a pair of other images is no concern of theirs; a file without digests is not checked
    write_matches(path, "b.png", "c.png", [], len(keypoints) - 1, 2, digests=(d1, "x"))
    write_matches(tmp_path / "m2.h5", "a.png", "b.png", [], len(keypoints) - 2, len(keypoints) - 1)
    with pytest.raises(ValueError, match="holds no features of 'z.png'"):
        features_digest(feats, "z.png")


# --- even view counts: keypoints in the frame of the centre view written with them -------

def four_blobs():
    B = synthetic.Blob
    return [B(30, 30, 4, -1.5, 0.4), B(90, 30, 4, 1.5, -0.4), B(30, 70, 4, 1.0, 0.4), B(90, 70, 4, -1.0, -0.4)]


@pytest.mark.parametrize("views", [(4, 4), (4, 5), (5, 4)])
def test_keypoints_in_centre_view_are_where_that_view_shows_them(views):
    """LiFF's centre frame lies between views for an even count; the view (T//2, S//2)
    that is written with the keypoints shows a blob of slope m m/2 px off per even axis."""
    from liff.feature_file import centre_view, keypoints_in_centre_view

    blobs = four_blobs()
    lf = synthetic.render_disks(blobs, views + (100, 120))
    keypoints, _ = liff.LiFF.create(firstSlope=-2, lastSlope=2).detectAndCompute(lf, None)
    moved = keypoints_in_centre_view(keypoints, lf.shape)
    view = centre_view(lf).astype(np.float64)
    weight = np.abs(view - 0.5)
    yy, xx = np.mgrid[:view.shape[0], :view.shape[1]]
    for b in blobs:
        i = int(np.argmin([np.hypot(k.pt[0] - b.x, k.pt[1] - b.y) for k in keypoints]))
        window = (np.abs(xx - b.x) < 10) & (np.abs(yy - b.y) < 10)
        seen = [(weight * window * c).sum() / (weight * window).sum() for c in (xx, yy)]
        assert np.hypot(*np.subtract(moved[i].pt, seen)) < 0.05  # where the view shows it
        assert np.hypot(*np.subtract(keypoints[i].pt, seen)) > 0.45  # not the centre frame
        assert (moved[i].size, moved[i].angle, moved[i].class_id) == (
            keypoints[i].size, keypoints[i].angle, keypoints[i].class_id)
    assert keypoints_in_centre_view(keypoints, (5, 5, 100, 120)) == tuple(keypoints)  # odd: as given


def test_even_view_counts_export_the_centre_views_frame(tmp_path, monkeypatch):
    from liff import _tasks as detect_cli
    from liff.cli import main
    from liff.feature_file import keypoints_in_centre_view, load_features

    drawn = []
    original = detect_cli.draw_keypoints_by_slope
    monkeypatch.setattr(detect_cli, "draw_keypoints_by_slope",
                        lambda view, kps, *a, **k: drawn.append(kps) or original(view, kps, *a, **k))
    for views in (4, 5):
        lf = tmp_path / f"v{views}.npz"
        assert main(["synth", "disks", "--out", str(lf), "--views", str(views), "--size", "96", "128",
                     "--seed", "3"]) == 0
        feats, out = tmp_path / f"feats{views}.h5", tmp_path / f"v{views}-feats.npz"
        assert main(["detect", str(lf), "--out", str(out), "--plot", str(tmp_path / f"v{views}.png"),
                     "--hloc", str(feats)]) == 0
        features = load_features(out)
        kp = hloc_get_keypoints(feats, f"v{views}-feats.png")
        pts = np.array([k.pt for k in features.keypoints])
        if views == 5:  # bit for bit as written from the keypoints as they are
            write_features(tmp_path / "ref.h5", "ref.png", features.keypoints, features.descriptors, (128, 96))
            np.testing.assert_array_equal(kp, hloc_get_keypoints(tmp_path / "ref.h5", "ref.png"))
            assert [k.pt for k in drawn[-1]] == [k.pt for k in features.keypoints]
        else:
            shift = features.slopes[:, None] * 0.5
            assert np.abs(features.slopes).max() > 0.2
            np.testing.assert_allclose(kp, pts - shift, atol=1e-4)
            expected = keypoints_in_centre_view(features.keypoints, (4, 4, 96, 128))
            np.testing.assert_allclose([k.pt for k in drawn[-1]], [k.pt for k in expected], atol=1e-4)


# --- write_matches: indices, distances, scores, pairs in either order; names -------------

@pytest.mark.parametrize("match, message", [
    (cv2.DMatch(0, 1_000_000, 0.1), r"trainIdx 1000000; expected in \[0, 4\), a keypoint of 'b.png'"),
    (cv2.DMatch(0, -7, 0.1), r"trainIdx -7; expected in \[0, 4\)"),
    (cv2.DMatch(0, -1, 0.1), r"trainIdx -1; expected in \[0, 4\)"),
    (cv2.DMatch(0, 4, 0.1), r"trainIdx 4; expected in \[0, 4\)"),
    (cv2.DMatch(3, 0, 0.1), r"queryIdx 3; expected in \[0, 3\), a keypoint of 'a.png'"),
    (cv2.DMatch(0, 1, -0.5), r"distance -0.5; expected a descriptor distance, finite and >= 0"),
    (cv2.DMatch(0, 1, float("nan")), r"distance nan; expected"),
    (cv2.DMatch(0, 1, float("inf")), r"distance inf; expected"),
])
def test_write_matches_checks_both_images_keypoints_and_the_distance(tmp_path, match, message):
    with pytest.raises(ValueError, match=message):
        write_matches(tmp_path / "m.h5", "a.png", "b.png", [match], 3, 4)
    assert not (tmp_path / "m.h5").exists() or "a.png" not in h5py.File(tmp_path / "m.h5", "r")


def test_write_matches_checks_the_counts(tmp_path):
    for bad in (-1, 2.5, "3", True):
        with pytest.raises(ValueError, match=r"num_keypoints1 .*; expected a keypoint count"):
            write_matches(tmp_path / "m.h5", "a.png", "b.png", [], 3, bad)


def test_scores_are_the_descriptors_cosine_similarity(tmp_path, two_views):
    """hloc's nearest-neighbour matcher scores normalised descriptors by their dot
    product; its min_match_score thresholds must mean the same for liff's files."""
    from liff.hloc import match_scores

    _, (keypoints, descriptors) = two_views
    other = np.roll(descriptors, 1, axis=0)  # every descriptor against its neighbour's
    matches = [cv2.DMatch(i, i, float(np.linalg.norm(descriptors[i] - other[i])))
               for i in range(len(keypoints))]
    path = tmp_path / "m.h5"
    write_matches(path, "a.png", "b.png", matches, len(keypoints), len(keypoints))
    _, scores = hloc_get_matches(path, "a.png", "b.png")
    cosine = np.sum(descriptors * other, 1) / np.linalg.norm(descriptors, axis=1) / np.linalg.norm(other, axis=1)
    np.testing.assert_allclose(scores, np.clip(cosine, 0, 1), atol=0.01)
    assert scores.min() >= 0 and scores.max() <= 1 and np.median(scores) > 0.2
    assert match_scores([0.0])[0] == 1 and match_scores([2 * 512.0])[0] == 0  # same, opposite


def test_a_pair_is_found_in_either_order(tmp_path):
    path = tmp_path / "m.h5"
    write_matches(path, "a.png", "b.png", [cv2.DMatch(0, 1, 10.0)], 2, 3)
    with pytest.raises(ValueError, match=r"already holds the pair 'a.png/b.png'"):
        write_matches(path, "b.png", "a.png", [cv2.DMatch(1, 0, 10.0)], 3, 2)
    write_matches(path, "b.png", "a.png", [cv2.DMatch(1, 0, 10.0)], 3, 2, overwrite=True)
    with h5py.File(path, "r") as f:
        assert "a.png/b.png" not in f and "b.png/a.png" in f  # one group, as find_pair reads it
        assert list(f["b.png/a.png"]["matches0"][()]) == [-1, 0, -1]


@pytest.mark.parametrize("name, message", [
    ("my scene.png", "holds whitespace"), ("a\nb.png", "holds whitespace"), ("a\tb.png", "holds whitespace"),
    ("../x.png", r"holds a '\.' or '\.\.' part"), ("a/../b.png", r"'\.\.' part"), ("./a.png", r"'\.' or"),
])
def test_names_hloc_cannot_hold_are_refused(tmp_path, two_views, name, message):
    _, (keypoints, descriptors) = two_views
    with pytest.raises(ValueError, match=message):
        write_features(tmp_path / "f.h5", name, keypoints, descriptors, (128, 96))
    with pytest.raises(ValueError, match=message):
        write_matches(tmp_path / "m.h5", "ok.png", name, [], 0, 0)


def test_an_image_name_is_not_the_folder_of_others(tmp_path, two_views):
    _, (keypoints, descriptors) = two_views
    path = tmp_path / "f.h5"
    write_features(path, "lf0/centre.png", keypoints, descriptors, (128, 96))
    for overwrite in (False, True):
        with pytest.raises(ValueError, match=r"'lf0' is a folder of other images' names there "
                                             r"\(lf0/centre.png\)"):
            write_features(path, "lf0", keypoints, descriptors, (128, 96), overwrite=overwrite)
    write_features(path, "lf1", keypoints, descriptors, (128, 96))
    with pytest.raises(ValueError, match=r"'lf1' holds an image's features; expected 'lf1/c.png' not"):
        write_features(path, "lf1/c.png", keypoints, descriptors, (128, 96))
    with h5py.File(path, "r") as f:
        assert sorted(f) == ["lf0", "lf1"] and sorted(f["lf0"]) == ["centre.png"]


# --- second break test (issue 29): refusals before anything is written -------------------

@pytest.fixture(scope="module")
def arc(tmp_path_factory):
    """Three tiny poses, their feature files, an hloc features file and a matches file."""
    from liff.cli import main

    root = tmp_path_factory.mktemp("arc")
    assert main(["synth", "poses", "--out", str(root / "arc"), "--views", "3", "--size", "64", "80",
                 "--poses", "3", "--quiet"]) == 0
    feats, matches = root / "feats.h5", root / "matches.h5"
    assert main(["detect", str(root / "arc"), "--out", str(root / "f"), "--hloc", str(feats), "--quiet"]) == 0
    assert main(["match", str(root / "f" / "pose00.npz"), str(root / "f" / "pose01.npz"), "--hloc",
                 str(matches), "--hloc-features", str(feats)]) == 0
    return root


def snapshot(path):
    return path.read_bytes()


def test_an_hloc_file_of_the_other_kind_is_refused(arc, tmp_path, capsys, two_views):
    from liff.cli import main

    feats, matches = arc / "feats.h5", arc / "matches.h5"
    before = snapshot(feats), snapshot(matches)
    out = tmp_path / "f"
    assert main(["detect", str(arc / "arc" / "pose00.npz"), "--out", str(out / "pose00.npz"),
                 "--hloc", str(matches)]) == 1
    error = capsys.readouterr().err
    assert "is an hloc matches file" in error and "expected an hloc features file" in error
    assert "Traceback" not in error and not out.exists()
    f0, f1 = (str(arc / "f" / f"pose0{i}.npz") for i in (0, 2))
    assert main(["match", f0, f1, "--hloc", str(feats), "--hloc-features", str(feats)]) == 1
    assert "is an hloc features file" in capsys.readouterr().err
    assert (snapshot(feats), snapshot(matches)) == before
    _, (keypoints, descriptors) = two_views
    with pytest.raises(ValueError, match="matches.h5 is an hloc matches file"):
        write_features(matches, "z.png", keypoints, descriptors, (128, 96))
    with pytest.raises(ValueError, match="feats.h5 is an hloc features file"):
        write_matches(feats, "pose00.png", "pose02.png", [], 0, 0)
    assert (snapshot(feats), snapshot(matches)) == before


def test_match_checks_the_features_file_the_matches_index(arc, tmp_path, capsys):
    from liff.cli import main

    feats = arc / "feats.h5"
    f0, f2 = (str(arc / "f" / f"pose0{i}.npz") for i in (0, 2))
    stale = tmp_path / "other" / "pose00.npz"  # other settings, not exported to feats.h5
    assert main(["detect", str(arc / "arc" / "pose00.npz"), "--out", str(stale), "--nfeatures", "5",
                 "--quiet"]) == 0
    new = tmp_path / "m.h5"
    assert main(["match", str(stale), f2, "--hloc", str(new), "--hloc-features", str(feats)]) == 1
    error = capsys.readouterr().err
    assert "pose00.png (" in error and "stale" in error and "liff detect --hloc" in error
    assert "pose02.png" not in error.split("holds other features of")[1].split("than")[0]
    assert not new.exists()
    assert main(["match", f0, f2, "--hloc", str(new)]) == 1
    assert "--hloc without --hloc-features" in capsys.readouterr().err
    assert main(["match", f0, f2, "--hloc-features", str(feats)]) == 1
    assert "--hloc-features without --hloc" in capsys.readouterr().err
    assert main(["match", f0, f2, "--hloc", str(new), "--hloc-features", str(tmp_path / "none.h5")]) == 1
    assert "does not exist" in capsys.readouterr().err and not new.exists()
    assert main(["match", f0, f2, "--hloc", str(new), "--hloc-features", str(feats)]) == 0


def test_write_matches_checks_the_features_file(arc, tmp_path):
    from liff.hloc import features_digest

    feats = arc / "feats.h5"
    d1 = features_digest(feats, "pose01.png")
    with h5py.File(feats, "r") as f:
        n0, n1 = len(f["pose00.png"]["keypoints"]), len(f["pose01.png"]["keypoints"])
    path = tmp_path / "m.h5"
    with pytest.raises(ValueError, match=r"other features of pose00.png \(other features there\)"):
        write_matches(path, "pose00.png", "pose01.png", [], n0, n1, digests=("x", d1), features=feats)
    with pytest.raises(ValueError, match=rf"pose01.png \({n1} keypoints there, {n1 + 1} matched\)"):
        write_matches(path, "pose00.png", "pose01.png", [], n0, n1 + 1, features=feats)
    with pytest.raises(ValueError, match=r"holds no features of 'q.png'"):
        write_matches(path, "pose00.png", "q.png", [], n0, 0, features=feats)
    assert not path.exists()
    write_matches(path, "pose00.png", "pose01.png", [], n0, n1, features=feats)  # its digests recorded
    with h5py.File(path, "r") as f:
        assert f["pose00.png/pose01.png"].attrs["liff_features1"] == d1


def test_detect_says_which_feature_files_it_wrote_when_hloc_refuses(arc, tmp_path, capsys):
    from liff.cli import main

    feats = tmp_path / "feats.h5"
    feats.write_bytes((arc / "feats.h5").read_bytes())
    before = snapshot(feats)
    out = tmp_path / "other" / "pose00.npz"
    assert main(["detect", str(arc / "arc" / "pose00.npz"), "--out", str(out), "--nfeatures", "5",
                 "--hloc", str(feats)]) == 1
    error = capsys.readouterr().err
    assert "other features of pose00.png" in error and f"the feature files were written ({out})" in error
    assert out.exists() and snapshot(feats) == before


def test_an_image_pair_of_one_name_is_refused(arc, tmp_path, capsys):
    from liff.cli import main

    twin = tmp_path / "twin" / "pose00.npz"
    twin.parent.mkdir()
    twin.write_bytes((arc / "f" / "pose00.npz").read_bytes())
    new = tmp_path / "m.h5"
    assert main(["match", str(arc / "f" / "pose00.npz"), str(twin), "--hloc", str(new),
                 "--hloc-features", str(arc / "feats.h5")]) == 1
    assert "both images are named 'pose00.png'" in capsys.readouterr().err and not new.exists()
    with pytest.raises(ValueError, match="both images are named 'a.png'"):
        write_matches(new, "a.png", "a.png", [], 0, 0)


def test_hloc_images_are_not_overwritten_unasked(arc, tmp_path, capsys):
    """An image in --hloc-images that the features file holds no features of (another
    features file's export, or the user's) is refused, and with --overwrite replaced
    and named."""
    from liff.cli import main

    images = tmp_path / "images"
    images.mkdir()
    (images / "pose00.png").write_bytes(b"someone else's")
    args = ["detect", str(arc / "arc" / "pose00.npz"), "--out", str(tmp_path / "f" / "pose00.npz"),
            "--hloc", str(tmp_path / "feats.h5"), "--hloc-images", str(images)]
    assert main(args) == 1
    error = capsys.readouterr().err
    assert str(images / "pose00.png") in error and "--overwrite" in error
    assert (images / "pose00.png").read_bytes() == b"someone else's"
    assert not (tmp_path / "f").exists() and not (tmp_path / "feats.h5").exists()
    assert main(args + ["--overwrite"]) == 0
    # break test of issue 29: the image was replaced without a word; named as groups are
    assert (f"hloc: replaced {images / 'pose00.png'} (--overwrite): files --hloc-images held "
            f"that were not centre views exported with {tmp_path / 'feats.h5'}"
            in capsys.readouterr().err)
    assert main(args) == 0  # now its own export: a re-run is no clash
    assert "hloc: replaced" not in capsys.readouterr().err
    assert cv2.imread(str(images / "pose00.png"), cv2.IMREAD_UNCHANGED).ndim == 2


def test_detect_refuses_names_hloc_cannot_hold_before_writing(arc, tmp_path, capsys):
    from liff.cli import main

    out = tmp_path / "f" / "my pose.npz"
    assert main(["detect", str(arc / "arc" / "pose00.npz"), "--out", str(out),
                 "--hloc", str(tmp_path / "feats.h5")]) == 1
    assert "'my pose.png' holds whitespace" in capsys.readouterr().err
    assert not out.exists() and not (tmp_path / "feats.h5").exists()


@pytest.mark.parametrize("size", [(128, 96, 1), (-128, 96), (128.5, 96), (0, 96), (np.nan, 96), 128])
def test_write_features_checks_the_image_size(tmp_path, two_views, size):
    _, (keypoints, descriptors) = two_views
    with pytest.raises(ValueError, match=r"image_size .*; expected \(width, height\), two whole"):
        write_features(tmp_path / "f.h5", "a.png", keypoints, descriptors, size)


def test_write_features_checks_keypoints_and_names(tmp_path, two_views):
    _, (keypoints, descriptors) = two_views
    bad = list(keypoints)
    bad[1] = cv2.KeyPoint(float("nan"), 3.0, 2.0)
    with pytest.raises(ValueError, match="keypoint 1 at .*; expected finite"):
        write_features(tmp_path / "f.h5", "a.png", bad, descriptors, (128, 96))
    for name in ("q/", "a\\\\b.png"):
        with pytest.raises(ValueError, match="expected a relative path with '/' between"):
            write_features(tmp_path / "f.h5", name, keypoints, descriptors, (128, 96))
    assert not (tmp_path / "f.h5").exists()


def test_write_matches_checks_its_argument_types(tmp_path):
    with pytest.raises(TypeError, match=r"matches holds \(0, 1, 0.5\); expected cv2.DMatch"):
        write_matches(tmp_path / "m.h5", "a.png", "b.png", [(0, 1, 0.5)], 3, 3)
    with pytest.raises(ValueError, match=r"digests \('x',\); expected two strings"):
        write_matches(tmp_path / "m.h5", "a.png", "b.png", [], 3, 3, digests=("x",))


# --- third break test (issue 29): a pair that does not involve the images matched now --

def test_match_refuses_a_matches_file_holding_any_stale_pair(arc, tmp_path):
    """Matching pose02 with pose00 into a matches file whose pose00/pose01 pair was made
    against features of pose01 that the features file no longer holds is refused: that
    file would index keypoints that are not there, whichever pair is added."""
    import shutil

    from liff.cli import main

    feats, matches = tmp_path / "feats.h5", tmp_path / "matches.h5"
    shutil.copy(arc / "feats.h5", feats)
    shutil.copy(arc / "matches.h5", matches)  # holds pose00.png/pose01.png
    redone = tmp_path / "redone" / "pose01.npz"  # pose01 with other settings, re-exported
    assert main(["detect", str(arc / "arc" / "pose01.npz"), "--out", str(redone),
                 "--contrast-threshold", "0.08", "--hloc", str(feats), "--overwrite",
                 "--quiet"]) == 0
    before = snapshot(matches)
    f0, f2 = (str(arc / "f" / f"pose0{i}.npz") for i in (0, 2))
    with h5py.File(feats, "r") as f:
        counts = [len(f[name]["keypoints"]) for name in ("pose02.png", "pose00.png")]
    with pytest.raises(ValueError, match=r"pose00.png/pose01.png \(pose01.png changed\)"):
        write_matches(matches, "pose02.png", "pose00.png", [], *counts, features=feats)
    assert main(["match", f2, f0, "--hloc", str(matches), "--hloc-features", str(feats)]) == 1
    assert snapshot(matches) == before
    # Into a new matches file the same pair is fine.
    assert main(["match", f2, f0, "--hloc", str(tmp_path / "new.h5"), "--hloc-features",
                 str(feats)]) == 0


@pytest.mark.parametrize("kind", ["npz", "text", "folder"])
def test_a_features_file_that_is_no_hdf5_file_is_refused_clearly(arc, tmp_path, capsys, kind):
    from liff.cli import main

    wrong = {"npz": arc / "f" / "pose01.npz", "folder": arc / "f",
             "text": tmp_path / "notes.txt"}[kind]
    if kind == "text":
        wrong.write_text("not hdf5")
    f0, f1 = (str(arc / "f" / f"pose0{i}.npz") for i in (0, 1))
    assert main(["match", f0, f1, "--hloc", str(tmp_path / "m.h5"), "--hloc-features",
                 str(wrong)]) == 1
    err = capsys.readouterr().err
    assert ("is a folder" if kind == "folder" else "is not an HDF5 file") in err
    assert "Unable to" not in err and not (tmp_path / "m.h5").exists()


def test_images_of_another_features_file_are_named_when_replaced(arc, tmp_path):
    """Break test of issue 29: exporting into the images folder of another features file
    with overwrite replaced its images silently; refused without overwrite, and named
    in Added.replaced_images with it. The features file's own images are not named."""
    from liff.hloc import add_feature_files

    images = tmp_path / "images"
    pose = arc / "f" / "pose00.npz"
    first = add_feature_files(tmp_path / "a.h5", [pose], images)
    assert first.replaced_images == [] and (images / "pose00.png").exists()
    with pytest.raises(ValueError, match=r"pose00.png exist\(s\) and .*b.h5 holds no features"):
        add_feature_files(tmp_path / "b.h5", [pose], images)
    assert not (tmp_path / "b.h5").exists()
    second = add_feature_files(tmp_path / "b.h5", [pose], images, overwrite=True)
    assert second.replaced_images == [str(images / "pose00.png")]
    assert add_feature_files(tmp_path / "b.h5", [pose], images, overwrite=True).replaced_images == []
