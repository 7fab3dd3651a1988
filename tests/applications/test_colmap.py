"""liff.colmap: the COLMAP database, matching, mapping and the paper's SfM metrics.

pycolmap is a test dependency (the ``test`` extra): these tests fail, not skip, without it.
"""

import os
import re
from pathlib import Path

import cv2
import numpy as np
import pycolmap  # a missing pycolmap must fail here, loudly
import pytest

import liff
from liff import captures, colmap, preprocess

THRESHOLDS = dict(contrastThreshold=0.02, edgeThreshold=10)


@pytest.fixture(scope="module")
def scene():
    """Centre views of an easy textured scene from 4 poses, with cv2.SIFT features."""
    cap = captures.make_capture(seed=0, n_poses=4, views=(1, 1), size=(240, 320))
    sift = cv2.SIFT.create(**THRESHOLDS)
    images = []
    for i, view in enumerate(cap.centre_views()):
        grey = colmap.prepare_light_field(view)
        keypoints, descriptors = sift.detectAndCompute(grey, None)
        images.append(colmap.FeatureImage(f"pose{i}.png", grey, keypoints, descriptors))
    return cap, images


@pytest.fixture(scope="module")
def reconstructed(scene, tmp_path_factory):
    cap, images = scene
    work = tmp_path_factory.mktemp("sfm")
    database, image_dir = work / "database.db", work / "images"
    k = cap.intrinsics
    ids = colmap.write_database(database, image_dir, images, focal=k.focal, principal_point=(k.cx, k.cy))
    colmap.match(database)
    result = colmap.reconstruct(database, image_dir, work / "sparse", mapper="default")
    return database, image_dir, ids, result


def test_database_round_trip(scene, reconstructed):
    cap, images = scene
    database, image_dir, ids, _ = reconstructed
    with pycolmap.Database.open(str(database)) as db:
        assert db.num_images() == len(images) and db.num_cameras() == 1
        camera = db.read_all_cameras()[0]
        # COLMAP's pixel centres are at +0.5.
        assert camera.model_name == "SIMPLE_PINHOLE" and camera.has_prior_focal_length
        assert list(camera.params) == pytest.approx([cap.intrinsics.focal, 160.0, 120.0])
        assert db.num_keypoints() == sum(len(im.keypoints) for im in images)
        for image_id, im in zip(ids, images):
            assert db.read_image(image_id).name == im.name
            stored = db.read_keypoints(image_id)
            assert stored.shape == (len(im.keypoints), 4)
            pts = np.array([k.pt for k in im.keypoints])
            assert np.allclose(stored[:, :2], pts + 0.5, atol=1e-4)
            assert np.allclose(stored[:, 2], [k.size / 2 for k in im.keypoints], rtol=1e-6)
            descriptors = db.read_descriptors(image_id).data
            assert descriptors.dtype == np.uint8
            assert np.array_equal(descriptors, im.descriptors.astype(np.uint8))
            assert os.path.isfile(image_dir / im.name)
            assert np.array_equal(cv2.imread(str(image_dir / im.name), cv2.IMREAD_UNCHANGED), im.image)


def test_keypoint_orientation_and_scale():
    keypoints = [cv2.KeyPoint(10.0, 20.0, 8.0, 90.0), cv2.KeyPoint(0.0, 0.0, 3.0, -1),
                 cv2.KeyPoint(5.0, 6.0, 2.0, 270.0)]
    out = colmap.keypoints_to_colmap(keypoints)
    assert out.dtype == np.float32 and out.shape == (3, 4)
    # cv2's 90 degrees (towards +y, image coordinates) is COLMAP's pi/2; 270 is -pi/2.
    assert out[0] == pytest.approx([10.5, 20.5, 4.0, np.pi / 2])
    assert out[1] == pytest.approx([0.5, 0.5, 1.5, 0.0])  # no orientation
    assert out[2, 3] == pytest.approx(-np.pi / 2)
    assert colmap.keypoints_to_colmap([]).shape == (0, 4)


def _colmaps_own_keypoints(image, tmp_path):
    """COLMAP's SIFT on ``image`` (uint8 grey), read back from its database as
    (x, y, scale, orientation), the way COLMAP's matcher reads liff's."""
    (tmp_path / "images").mkdir()
    cv2.imwrite(str(tmp_path / "images" / "a.png"), image)
    options = pycolmap.FeatureExtractionOptions()
    options.num_threads = 1
    pycolmap.extract_features(tmp_path / "own.db", tmp_path / "images", extraction_options=options,
                              device=pycolmap.Device.cpu)
    with pycolmap.Database.open(str(tmp_path / "own.db")) as db:
        affine = db.read_keypoints(db.read_all_images()[0].image_id)  # x, y, a11, a12, a21, a22
    return np.c_[affine[:, :2], np.hypot(affine[:, 2], affine[:, 4]), np.arctan2(affine[:, 4], affine[:, 2])]


def _orientation_differences(ours, theirs):
    """For each of ``ours`` (COLMAP rows) with a keypoint of ``theirs`` within 0.5 px and
    5% in scale: the smallest orientation difference (radians) to one of those."""
    from scipy.spatial import cKDTree

    near = cKDTree(theirs[:, :2]).query_ball_point(ours[:, :2], 0.5)
    out = []
    for row, candidates in zip(ours, near):
        same = [j for j in candidates if abs(np.log(theirs[j, 2] / row[2])) < 0.05]
        if same:
            turn = (theirs[same, 3] - row[3] + np.pi) % (2 * np.pi) - np.pi
            out.append(np.abs(turn).min())
    return np.array(out)


def _textures():
    """Blurred noise at two sizes, a rotated copy, and a real view when the HCI data is
    here: images of more than one size and content."""
    rng = np.random.default_rng(7)
    images = []
    for shape, blur in (((240, 320), 3.0), ((180, 150), 2.0)):
        image = cv2.GaussianBlur(rng.random(shape).astype(np.float32), (0, 0), blur)
        images.append(cv2.normalize(image, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8))
    turn = cv2.getRotationMatrix2D((160, 120), 30, 1.0)  # 30 degrees counter-clockwise
    yield from images
    yield cv2.warpAffine(images[0], turn, (320, 240))
    cotton = Path(__file__).resolve().parents[2].parent / "shared/data/hci/cotton/input_Cam040.png"
    if cotton.is_file():
        yield cv2.imread(str(cotton), cv2.IMREAD_GRAYSCALE)[128:384, 128:384]


@pytest.mark.parametrize("index", range(4))
def test_orientations_agree_with_colmaps_own_sift(index, tmp_path):
    """Keypoints converted by keypoints_to_colmap point the way COLMAP's own SIFT
    points at the same place and scale (issue 26: they were mirrored, a median 68 degrees
    off), for cv2.SIFT's keypoints and liff's."""
    images = list(_textures())
    if index >= len(images):
        pytest.skip("HCI 'cotton' not found")
    image = images[index]
    theirs = _colmaps_own_keypoints(image, tmp_path)
    for detector in (cv2.SIFT_create(contrastThreshold=0.02), liff.LiFF.create()):
        ours = colmap.keypoints_to_colmap(detector.detect(image, None))
        turn = _orientation_differences(ours, theirs)
        assert len(turn) >= 20, type(detector)
        assert np.degrees(np.median(turn)) < 5, type(detector)
        # The mirrored convention would be far off on the same keypoints.
        mirrored = _orientation_differences(ours * [1, 1, 1, -1], theirs)
        assert np.degrees(np.median(mirrored)) > 30


def test_reconstruction_of_an_easy_scene(scene, reconstructed):
    cap, images = scene
    _, _, ids, result = reconstructed
    assert result.success and result.num_images == 4
    best = result.best
    assert best.num_reg_images() == 4 and best.num_points3D() > 200
    # Relative rotations between registered images match the ground truth.
    by_name = {im.name: im for im in best.images.values()}
    for a in range(4):
        for b in range(a + 1, 4):
            ra = by_name[images[a].name].cam_from_world().rotation.matrix()
            rb = by_name[images[b].name].cam_from_world().rotation.matrix()
            truth = cap.poses[b].rotation @ cap.poses[a].rotation.T
            error = np.degrees(np.arccos(np.clip((np.trace(truth.T @ rb @ ra.T) - 1) / 2, -1, 1)))
            assert error < 0.5


def test_table_metrics_are_consistent(scene, reconstructed):
    _, images = scene
    database, _, _, result = reconstructed
    m = colmap.table_metrics(database, result)
    assert m["passed"] and m["registered"] == 1.0
    assert m["keypoints_per_image"] == pytest.approx(np.mean([len(im.keypoints) for im in images]))
    assert 0 < m["inlier_matches_per_image"] <= m["putative_matches_per_image"]
    assert m["precision"] == pytest.approx(m["inlier_matches_per_image"] / m["putative_matches_per_image"])
    for key in ("match_ratio", "precision", "matching_score"):
        assert 0 < m[key] <= 1
    assert m["matching_score"] <= m["match_ratio"]
    # A keypoint takes part in at most 3 matches (one per other image), so:
    assert m["putative_matches_per_image"] * 2 <= 3 * m["match_ratio"] * m["keypoints_per_image"] + 1e-9
    assert m["points3D"] == result.best.num_points3D()
    assert m["track_length"] >= 2 and m["track_length"] <= 4
    # Without a reconstruction the model columns are empty.
    none = colmap.table_metrics(database, None)
    assert not none["passed"] and none["points3D"] == 0 and np.isnan(none["track_length"])
    assert none["precision"] == m["precision"]


def test_permissive_mapper_keeps_more_points(reconstructed, tmp_path):
    database, image_dir, _, default = reconstructed
    permissive = colmap.reconstruct(database, image_dir, tmp_path / "sparse", mapper="permissive")
    assert permissive.success
    # It keeps two-view tracks, which the default mapper ignores.
    assert permissive.best.num_points3D() > default.best.num_points3D()
    options = colmap.mapper_options("permissive")
    assert not options.triangulation.ignore_two_view_tracks
    assert options.mapper.init_min_num_inliers < colmap.mapper_options().mapper.init_min_num_inliers
    with pytest.raises(ValueError, match="mapper"):
        colmap.mapper_options("lenient")


def test_root_sift_matches_liffs_own():
    rng = np.random.default_rng(0)
    image = cv2.GaussianBlur(rng.random((96, 96)).astype(np.float32), (0, 0), 2) * 4
    plain = liff.LiFF.create(**THRESHOLDS)
    rooted = liff.LiFF.create(rootSift=True, **THRESHOLDS)
    keypoints, sift = plain.detectAndCompute(image)
    _, expected = rooted.compute(image, keypoints)
    ours = colmap.root_sift(sift)
    assert len(keypoints) > 10 and ours.dtype == np.uint8
    # Same normalisation, but ours starts from descriptors already rounded to 1/512, and
    # the square root magnifies that rounding near 0 (a SIFT entry of 0 may have been up
    # to 1/1024, whose root is 512 * sqrt(1/1024 / |d|_1), about 6 here).
    difference = np.abs(ours.astype(int) - expected.astype(int))
    assert difference.max() <= 8 and difference.mean() < 0.5
    ours, expected = ours.astype(float), expected.astype(float)
    cosine = (ours * expected).sum(1) / np.linalg.norm(ours, axis=1) / np.linalg.norm(expected, axis=1)
    assert cosine.min() > 0.995
    norms = np.linalg.norm(ours.astype(float), axis=1)
    assert np.all(np.abs(norms - 512) < 6)


def test_descriptor_errors():
    kps = [cv2.KeyPoint(1.0, 1.0, 2.0)] * 2
    good = np.full((2, 128), 40.0, np.float32)
    assert colmap.descriptors_to_colmap(good, 2).dtype == np.uint8
    with pytest.raises(ValueError, match="shape"):
        colmap.descriptors_to_colmap(good[:, :64], 2)
    with pytest.raises(ValueError, match="2 descriptors for 3 keypoints"):
        colmap.descriptors_to_colmap(good, 3)
    with pytest.raises(ValueError, match="unit-norm"):
        colmap.descriptors_to_colmap(good / 512, 2)
    with pytest.raises(ValueError, match=r"\[0, 255\]"):
        colmap.descriptors_to_colmap(good * 10, 2)
    with pytest.raises(ValueError, match="dtype"):
        colmap.descriptors_to_colmap(good.astype(np.complex64), 2)
    with pytest.raises(ValueError, match="None"):
        colmap.descriptors_to_colmap(None, len(kps))
    assert colmap.descriptors_to_colmap(None, 0).shape == (0, 128)


def test_write_database_errors(tmp_path):
    image = np.zeros((20, 30), np.uint8)
    one = colmap.FeatureImage("a.png", image, [cv2.KeyPoint(1.0, 1.0, 2.0)], np.full((1, 128), 9, np.uint8))
    with pytest.raises(ValueError, match="no images"):
        colmap.write_database(tmp_path / "a.db", tmp_path / "im", [])
    with pytest.raises(ValueError, match="repeat"):
        colmap.write_database(tmp_path / "b.db", tmp_path / "im", [one, one])
    other = colmap.FeatureImage("b.png", np.zeros((21, 30), np.uint8), [], None)
    with pytest.raises(ValueError, match="differ in size: a.png 30x20; b.png 30x21; expected one"):
        colmap.write_database(tmp_path / "c.db", tmp_path / "im", [one, other])
    bad = colmap.FeatureImage("b.png", image, one.keypoints * 2, one.descriptors)
    with pytest.raises(ValueError, match="1 descriptors for 2 keypoints"):
        colmap.write_database(tmp_path / "d.db", tmp_path / "im", [one, bad])
    assert not (tmp_path / "d.db").exists()  # nothing written when anything is wrong
    colmap.write_database(tmp_path / "e.db", tmp_path / "im", [one])
    with pytest.raises(ValueError, match="fresh"):
        colmap.write_database(tmp_path / "e.db", tmp_path / "im", [one])


def test_prepare_light_field_matches_the_papers_greyscale():
    rng = np.random.default_rng(1)
    lf = (0.2 + 0.3 * rng.random((3, 3, 40, 50, 3))).astype(np.float32)  # BGR
    grey = colmap.prepare_light_field(lf)
    assert grey.shape == (3, 3, 40, 50) and grey.dtype == np.uint8
    # liff.preprocess.prepare (luminance, gamma 0.5, one stretch for all views) in 8 bits
    expected = np.round(preprocess.prepare(lf) * 255)
    np.testing.assert_array_equal(grey, expected)
    assert grey.min() == 0 and grey.max() == 255  # stretched to the full range
    # One table for all views: equal inputs stay equal across views.
    same = np.broadcast_to(lf[1, 1, :, :, 1], (3, 3, 40, 50)).copy()
    assert (colmap.prepare_light_field(same) == colmap.prepare_light_field(same)[1, 1]).all()
    assert colmap.prepare_light_field(lf[1, 1]).shape == (40, 50)
    with pytest.raises(ValueError, match="shape"):
        colmap.prepare_light_field(np.zeros((2, 3, 4)))


def test_write_database_checks_names_before_writing(tmp_path):
    """A name without an image ending, or one that cannot be written, is a ValueError
    before the database exists, so the next run can use the same path."""
    image = np.zeros((20, 30), np.uint8)
    kps, desc = [cv2.KeyPoint(1.0, 1.0, 2.0)], np.full((1, 128), 9, np.uint8)
    good = colmap.FeatureImage("a.png", image, kps, desc)
    (tmp_path / "a_file").write_text("in the way")
    for folder, name, message in (("im", "pose0", "image ending"), ("im", "b.npy", "image ending"),
                                  ("a_file", "b.png", "cannot create the folder")):
        bad = colmap.FeatureImage(name, image, kps, desc)
        with pytest.raises(ValueError, match=message):
            colmap.write_database(tmp_path / "a.db", tmp_path / folder, [good, bad])
        assert not (tmp_path / "a.db").exists()
    assert colmap.write_database(tmp_path / "a.db", tmp_path / "im",
                                 [good, colmap.FeatureImage("B.JPG", image, kps, desc)]) == [1, 2]


def test_write_database_takes_images_as_to_display_scales_them(tmp_path):
    """uint16 (/65535), float (NaN as 0) and BGR images become the grey uint8 images
    liff.plot.to_display gives; other shapes and dtypes are ValueErrors."""
    rng = np.random.default_rng(3)
    images = {"u16.png": rng.integers(0, 65536, (20, 30), dtype=np.uint16),
              "float.png": rng.random((20, 30)),
              "bgr.png": rng.integers(0, 256, (20, 30, 3), dtype=np.uint8)}
    images["float.png"][0, 0] = np.nan
    feature_images = [colmap.FeatureImage(name, im, [], None) for name, im in images.items()]
    colmap.write_database(tmp_path / "a.db", tmp_path / "im", feature_images)
    for name, im in images.items():
        expected = cv2.cvtColor(liff.plot.to_display(im), cv2.COLOR_BGR2GRAY)
        np.testing.assert_array_equal(cv2.imread(str(tmp_path / "im" / name), cv2.IMREAD_UNCHANGED),
                                      expected)
    assert cv2.imread(str(tmp_path / "im" / "u16.png"), cv2.IMREAD_UNCHANGED).std() > 50  # not all 255
    assert cv2.imread(str(tmp_path / "im" / "float.png"), cv2.IMREAD_UNCHANGED)[0, 0] == 0
    grey = np.arange(256, dtype=np.uint8).reshape(16, 16)
    np.testing.assert_array_equal(colmap.grey_uint8_image(grey), grey)  # uint8 unchanged
    for bad, message in ((np.zeros((4, 5, 4), np.uint8), "shape"), (np.zeros(5), "shape"),
                         (np.zeros((4, 5), bool), "dtype")):
        with pytest.raises(ValueError, match=message):
            colmap.write_database(tmp_path / "b.db", tmp_path / "im",
                                  [colmap.FeatureImage("x.png", bad, [], None)])
    assert not (tmp_path / "b.db").exists()


def test_root_sift_checks_its_input():
    assert colmap.root_sift(None).shape == (0, 128)  # cv2.SIFT without keypoints
    assert colmap.root_sift(None).dtype == np.uint8
    assert colmap.root_sift(np.zeros((0, 128), np.float32)).shape == (0, 128)
    good = np.full((2, 128), 40.0, np.float32)
    np.testing.assert_array_equal(colmap.root_sift(good), colmap.root_sift(good.astype(np.uint8)))
    with pytest.raises(ValueError, match=r"shape \(2, 64\); expected \(N, 128\)"):
        colmap.root_sift(good[:, :64])
    with pytest.raises(ValueError, match="shape"):
        colmap.root_sift(good[0])
    bad = good.copy()
    bad[0, 0] = -1
    with pytest.raises(ValueError, match=">= 0"):
        colmap.root_sift(bad)
    bad[0, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        colmap.root_sift(bad)
    with pytest.raises(ValueError, match="dtype"):
        colmap.root_sift(good.astype(np.complex64))


@pytest.mark.parametrize("shape", [(40, 50), (40, 50, 1), (40, 50, 3), (3, 3, 40, 50),
                                   (3, 3, 40, 50, 1), (3, 3, 40, 50, 3), (3, 3, 40, 50, 4)])
def test_prepare_light_field_is_prepare_in_8_bits(shape):
    lf = np.random.default_rng(2).integers(0, 256, shape, dtype=np.uint8)
    grey = colmap.prepare_light_field(lf, equalise="cdf")
    np.testing.assert_array_equal(grey, np.round(preprocess.prepare(lf, equalize="cdf") * 255))
    assert grey.dtype == np.uint8
    with pytest.raises(ValueError, match=r"input of shape \(3, 3, 40, 50, 5\)"):
        colmap.prepare_light_field(np.zeros((3, 3, 40, 50, 5)))


def test_left_out_images_are_named_with_their_reason(scene, reconstructed, tmp_path):
    """Issue 26 item 7: a capture with no features, and one of another scene, are named
    with why they are not in the model; the registered ones are not listed."""
    cap, images = scene
    database, _, _, result = reconstructed
    assert colmap.left_out_images(database, result) == []
    blank = np.full_like(images[0].image, 128)
    rng = np.random.default_rng(3)
    noise = cv2.GaussianBlur(rng.random(blank.shape).astype(np.float32), (0, 0), 2.0)
    other = cv2.normalize(noise, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    sift = cv2.SIFT.create(**THRESHOLDS)
    extra = [colmap.FeatureImage("blank.png", blank, (), None),
             colmap.FeatureImage("other.png", other, *sift.detectAndCompute(other, None))]
    k = cap.intrinsics
    database = tmp_path / "database.db"
    colmap.write_database(database, tmp_path / "images", [*images[:2], extra[0], *images[2:], extra[1]],
                          focal=k.focal, principal_point=(k.cx, k.cy))
    colmap.match(database)
    result = colmap.reconstruct(database, tmp_path / "images", tmp_path / "sparse", mapper="default")
    assert result.best.num_reg_images() == 4
    left_out = dict(colmap.left_out_images(database, result))
    assert list(left_out) == ["blank.png", "other.png"]
    assert left_out["blank.png"] == "no features (0 keypoints)"
    assert left_out["other.png"].startswith("no verified match with any other image")
    # Without a model, every image is left out, each with its reason.
    everything = dict(colmap.left_out_images(database, None))
    assert len(everything) == 6 and everything["blank.png"] == left_out["blank.png"]
    assert "but not registered" in everything["pose0.png"]


def test_sfm_says_too_few_inliers_not_no_baseline(tmp_path, capsys, monkeypatch):
    """Issue 29: three tiny poses match with a handful of inliers; the empty model is
    for those, not for a missing baseline."""
    import json

    from liff.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["synth", "poses", "--out", "arc", "--views", "3", "--size", "64", "80", "--poses", "3",
                 "--quiet"]) == 0
    truth = json.load(open("arc.truth.json"))
    k = truth["intrinsics"]
    camera = ["--camera", str(k["focal"]), str(truth["baseline"]), str(k["cx"]), str(k["cy"]),
              "--focus-distance", str(truth["focus_depth"])]
    assert main(["sfm", "arc", "--workspace", "ws", *camera, "--quiet"]) == 1
    error = capsys.readouterr().err
    assert "no 3-D points" in error and "no baseline" not in error
    found = re.search(r"fewer inlier matches than the 15 COLMAP triangulates from: "
                      r"pose00.png-pose01.png \((\d+)\)", error)
    assert found and int(found[1]) < 15


def test_no_points_reason_names_the_pairs_below_colmaps_minimum():
    from types import SimpleNamespace

    from liff.cli.colmap import no_points_reason

    poses = {("a", "b"): SimpleNamespace(inliers=7), ("a", "c"): None, ("b", "c"): SimpleNamespace(inliers=40)}
    assert "a-b (7)" in no_points_reason(poses) and "b-c" not in no_points_reason(poses)
    assert "no baseline" in no_points_reason({("a", "b"): SimpleNamespace(inliers=40)})
    assert "no baseline" in no_points_reason(None)
