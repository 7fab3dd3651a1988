"""The ``liff`` console command, run in-process through liff.cli.main (and once as a
real subprocess): outputs, batches, skipping, and errors that name the file."""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys

import cv2
import numpy as np
import pytest

import liff
from liff.cli import main
from liff.feature_file import load_features


@pytest.fixture(scope="module")
def disk_npz(tmp_path_factory):
    """The paper's disk scene, small: 5x5 views of 96x96, as written by `liff synth`."""
    path = str(tmp_path_factory.mktemp("synth") / "disks.npz")
    assert main(["synth", "disks", "--out", path, "--views", "5", "--size", "96", "96"]) == 0
    return path


def test_synth_writes_light_field_and_truth(disk_npz):
    with np.load(disk_npz) as data:
        assert data["light_field"].shape == (5, 5, 96, 96)
        assert data["blobs"].shape == (26, 5)  # x, y, radius, slope, intensity
        assert np.all(np.abs(data["blobs"][:, 3]) <= 1)


def test_synth_refuses_to_overwrite(disk_npz, capsys):
    assert main(["synth", "disks", "--out", disk_npz]) == 1
    assert disk_npz in capsys.readouterr().err


def test_detect_writes_features_that_match_the_api(disk_npz, tmp_path, capsys):
    out, plot = tmp_path / "f.npz", tmp_path / "f.png"
    assert main(["detect", disk_npz, "--out", str(out), "--plot", str(plot),
                 "--contrast-threshold", "0.02"]) == 0
    features = load_features(out)
    with np.load(disk_npz) as data:
        lf = data["light_field"]
    kps, desc = liff.LiFF.create(contrastThreshold=0.02).detectAndCompute(lf, None)
    assert len(features.keypoints) == len(kps) > 10
    np.testing.assert_array_equal(features.descriptors, desc)
    np.testing.assert_allclose(features.slopes, liff.keypoint_slopes(kps), atol=1e-4)
    assert [k.pt for k in features.keypoints] == [k.pt for k in kps]
    assert features.centre_view.shape == (96, 96, 3)  # stored for display, BGR uint8
    assert cv2.imread(str(plot)) is not None
    assert features.meta["parameters"]["contrastThreshold"] == 0.02
    assert f"{len(kps)} features" in capsys.readouterr().out


def test_detect_batch_skips_existing_and_reports_bad_files(disk_npz, tmp_path, capsys):
    bad = tmp_path / "bad.npz"
    np.savez(bad, light_field=np.zeros((3, 3)))  # 2-D: not a light field
    out = tmp_path / "features"
    args = ["detect", disk_npz, str(bad), "--out", str(out)]
    assert main(args) == 1  # one file failed
    captured = capsys.readouterr()
    assert captured.err.count(str(bad)) == 1  # named once, as other liff errors are
    assert f"liff detect: {bad}" in captured.err and "ValueError" not in captured.err
    assert os.path.exists(out / "disks.npz") and not os.path.exists(out / "bad.npz")
    mtime = os.path.getmtime(out / "disks.npz")
    assert main(["detect", disk_npz, "--out", str(out)]) == 0
    assert "skipped 1" in capsys.readouterr().out
    assert os.path.getmtime(out / "disks.npz") == mtime


def test_detect_with_two_workers_equals_one(disk_npz, tmp_path):
    copy = tmp_path / "copy.npz"
    with np.load(disk_npz) as data:
        np.savez(copy, light_field=data["light_field"][:, :, ::-1])  # a different scene
    for workers, folder in ((1, "one"), (2, "two")):
        assert main(["detect", disk_npz, str(copy), "--out", str(tmp_path / folder),
                     "--workers", str(workers)]) == 0
    for name in ("disks.npz", "copy.npz"):
        a, b = load_features(tmp_path / "one" / name), load_features(tmp_path / "two" / name)
        np.testing.assert_array_equal(a.descriptors, b.descriptors)


def test_match_counts_inliers_between_shifted_light_fields(tmp_path, capsys):
    """A textured scene and the same scene shifted by (7, 4) px: many inliers, and the
    homography found is that translation."""
    from liff import synthetic

    scene = synthetic.textured_layers((5, 5, 120, 160), noise_variance=0).light_field
    a, b = scene[:, :, :100, :140], scene[:, :, 4:104, 7:147]
    np.save(tmp_path / "a.npy", a)
    np.save(tmp_path / "b.npy", b)
    plot = tmp_path / "m.png"
    assert main(["match", str(tmp_path / "a.npy"), str(tmp_path / "b.npy"), "--plot", str(plot)]) == 0
    out = capsys.readouterr().out
    counts = re.search(r"putative matches: (\d+); inliers \(homography, 3 px\): (\d+)", out)
    putative, inliers = int(counts.group(1)), int(counts.group(2))
    assert inliers >= 20 and inliers <= putative
    assert cv2.imread(str(plot)) is not None


def test_errors_name_the_file_and_exit_non_zero(tmp_path, capsys):
    missing = tmp_path / "nothing_here"
    assert main(["detect", str(missing), "--out", str(tmp_path / "x.npz")]) == 1
    assert str(missing) in capsys.readouterr().err
    not_features = tmp_path / "junk.npz"
    not_features.write_bytes(b"not a zip file")
    assert main(["match", str(not_features), str(not_features)]) == 1
    assert str(not_features) in capsys.readouterr().err


def test_console_script_runs_as_a_process(tmp_path):
    """`python -m liff.cli` (what the `liff` script runs) answers --help and exits 2 on
    bad usage, as argparse programs do."""
    ok = subprocess.run([sys.executable, "-m", "liff.cli", "--help"], capture_output=True, text=True)
    assert ok.returncode == 0 and "detect" in ok.stdout and "match" in ok.stdout
    bad = subprocess.run([sys.executable, "-m", "liff.cli", "detect"], capture_output=True, text=True)
    assert bad.returncode == 2 and "PATH" in bad.stderr


@pytest.mark.parametrize("fmt, name, extra", [("views", "views", []),
                                              ("eslf", "scene.eslf.png", ["--lenslet", "5"]),
                                              ("mosaic", "mosaic.png", ["--format", "mosaic",
                                                                        "--grid", "5", "5"])])
def test_synth_formats_read_back_for_detect(tmp_path, fmt, name, extra):
    """Every format `liff synth` writes is read by `liff detect` (16-bit PNGs), and the
    features equal those of the float light field up to the 16-bit rounding."""
    out = str(tmp_path / name)
    assert main(["synth", "layers", "--out", out, "--format", fmt, "--views", "5",
                 "--size", "64", "80"]) == 0
    assert os.path.exists(out + ".slopes.npy")
    assert main(["detect", out, "--out", str(tmp_path / "f.npz")] + extra) == 0
    features = load_features(tmp_path / "f.npz")
    lf = liff.synthetic.textured_layers((5, 5, 64, 80), noise_variance=0.0).light_field
    reference = liff.LiFF.create().detect(lf)
    assert abs(len(features.keypoints) - len(reference)) <= 0.1 * len(reference) + 2


@pytest.fixture(scope="module")
def capture_folder(tmp_path_factory):
    """Four camera poses of the built-in box scene, each a 5x5-view light field (.npy)."""
    from liff import captures

    folder = tmp_path_factory.mktemp("capture")
    capture = captures.make_capture(seed=0, n_poses=4, views=(5, 5), size=(240, 320))
    for i, lf in enumerate(capture.light_fields):
        np.save(folder / f"pose{i}.npy", lf)
    return folder, capture


def test_sfm_reconstructs_a_capture(capture_folder, tmp_path, capsys):
    folder, capture = capture_folder
    paths = sorted(str(p) for p in folder.glob("pose*.npy"))
    workspace = tmp_path / "ws"
    assert main(["sfm", *paths, "--workspace", str(workspace), "--preprocess",
                 "--contrast-threshold", "0.02", "--focal", str(capture.intrinsics.focal)]) == 0
    out = capsys.readouterr().out
    assert "4 images" in out and "a model in" in out
    assert re.search(r"registered images\s+100%", out)
    assert int(re.search(r"3D points\s+(\d+)", out).group(1)) > 100
    assert sorted(os.listdir(workspace / "images")) == [f"pose{i}.png" for i in range(4)]
    # A second run refuses the existing database unless told to overwrite it.
    assert main(["colmap", *paths, "--database", str(workspace / "database.db"),
                 "--image-dir", str(workspace / "images")]) == 1
    assert "fresh database" in capsys.readouterr().err


def _light_fields(source, folder, sizes):
    """One .npy a size (V, U) in ``folder``, cut from the light field ``source``; their
    paths."""
    folder.mkdir(exist_ok=True)
    paths = []
    for i, size in enumerate(sizes):
        with np.load(source) as data:
            lf = data["light_field"][:, :, :size[0], :size[1]]
        paths.append(str(folder / f"pose{i}.npy"))
        np.save(paths[-1], lf)
    return paths


def test_colmap_with_a_failed_input_writes_nothing_and_says_so(disk_npz, tmp_path, capsys):
    """Issue 32: one input with NaNs gave exit 1 and a database holding the other."""
    paths = _light_fields(disk_npz, tmp_path / "in", [(64, 64), (64, 64)])
    bad = np.load(paths[1]).astype(np.float32)
    bad[0, 0, 0, 0] = np.nan
    np.save(paths[1], bad)
    database, images = tmp_path / "ws" / "database.db", tmp_path / "ws" / "images"
    assert main(["colmap", *paths, "--database", str(database), "--image-dir", str(images)]) == 1
    err = capsys.readouterr().err
    assert "pose1.npy" in err and "1 of 2 input(s) failed" in err and "no database written" in err
    assert not (tmp_path / "ws").exists()


def test_sfm_on_views_of_different_sizes_names_them_and_leaves_no_workspace(disk_npz, tmp_path,
                                                                           capsys):
    """Issue 32: "images differ in size: [(240, 320), (256, 256)]", and an empty workspace."""
    paths = _light_fields(disk_npz, tmp_path / "in", [(64, 80), (64, 80), (72, 72)])
    workspace = tmp_path / "ws"
    assert main(["sfm", *paths, "--workspace", str(workspace)]) == 1
    err = capsys.readouterr().err
    assert (f"the inputs' centre views differ in size: {paths[0]}, {paths[1]} 80x64; "
            f"{paths[2]} 72x72; expected one camera") in err
    assert not workspace.exists()


def test_outputs_that_would_collide_are_refused(disk_npz, tmp_path, capsys):
    """a/lf_0.5.npy and b/lf_0.5.npy (or lf_0.5 / lf_0.7 cut at the first dot) must not
    overwrite each other's features."""
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        with np.load(disk_npz) as data:
            np.save(tmp_path / folder / "lf_0.5.npy", data["light_field"][:, :, :64, :64])
    np.save(tmp_path / "a" / "lf_0.7.npy", np.load(tmp_path / "a" / "lf_0.5.npy"))
    out = tmp_path / "out"
    assert main(["detect", str(tmp_path / "a" / "lf_0.5.npy"), str(tmp_path / "a" / "lf_0.7.npy"),
                 "--out", str(out)]) == 0
    assert sorted(n for n in os.listdir(out) if n.endswith(".npz")) == ["lf_0.5.npz", "lf_0.7.npz"]
    assert main(["detect", str(tmp_path / "a" / "lf_0.5.npy"), str(tmp_path / "b" / "lf_0.5.npy"),
                 "--out", str(tmp_path / "out2")]) == 1
    assert "would both write" in capsys.readouterr().err


def test_out_without_npz_ending_and_bad_plot_ending(disk_npz, tmp_path, capsys):
    out = tmp_path / "feats"
    assert main(["detect", disk_npz, "--out", str(out)]) == 0
    assert os.path.exists(str(out) + ".npz") and f"-> {out}.npz" in capsys.readouterr().out
    assert main(["detect", disk_npz, "--out", str(out)]) == 0  # the real file is seen
    assert "skipped 1" in capsys.readouterr().out
    assert main(["detect", disk_npz, "--out", str(tmp_path / "g.npz"), "--plot",
                 str(tmp_path / "g.foo")]) == 1
    assert "g.foo" in capsys.readouterr().err


def test_damaged_feature_file_is_an_error_not_a_traceback(disk_npz, tmp_path, capsys):
    good = tmp_path / "good.npz"
    assert main(["detect", disk_npz, "--out", str(good)]) == 0
    damaged = tmp_path / "damaged.npz"
    damaged.write_bytes(good.read_bytes()[:300])
    assert main(["match", str(damaged), str(good)]) == 1
    assert "damaged.npz" in capsys.readouterr().err


def test_sfm_needs_two_poses(disk_npz, tmp_path, capsys):
    assert main(["sfm", disk_npz, "--workspace", str(tmp_path / "ws")]) == 1
    assert "at least 2" in capsys.readouterr().err


def test_workers_share_the_cores():
    """N worker processes run LiFF on cpu_count // N threads each, not all cores each."""
    from liff.cli import common

    jobs = [(), (), ()]
    threads, failures = common.run_batch(liff.getNumThreads, jobs, 2, "detect", str)
    assert failures == 0
    assert threads == [max(1, (os.cpu_count() or 1) // 2)] * len(jobs)


@pytest.mark.parametrize("command", ["sfm", "colmap"])
def test_missing_pycolmap_is_a_message_not_a_traceback(disk_npz, tmp_path, capsys, monkeypatch, command):
    """Without pycolmap, `liff sfm` / `liff colmap` say how to install it (liff.colmap's
    message) and exit 1."""
    monkeypatch.setitem(sys.modules, "pycolmap", None)  # `import pycolmap` raises ImportError
    monkeypatch.delitem(sys.modules, "liff.colmap", raising=False)
    monkeypatch.delattr(liff, "colmap", raising=False)
    where = (["--workspace", str(tmp_path / "ws")] if command == "sfm" else
             ["--database", str(tmp_path / "d.db"), "--image-dir", str(tmp_path / "im")])
    assert main([command, disk_npz, disk_npz, *where]) == 1
    err = capsys.readouterr().err
    assert f"liff {command}: " in err and "pip install 'liff[sfm]'" in err
    assert "Traceback" not in err
    assert not (tmp_path / "d.db").exists()


def test_colmap_images_are_the_cli_centre_views(disk_npz, tmp_path):
    """`liff colmap` writes the centre view in 8 bits, as liff.plot.to_display scales it."""
    from liff.cli.colmap import features_for_colmap
    from liff.plot import to_display

    view, rows, _ = features_for_colmap(disk_npz, {}, False, dict(firstSlope=-1.0, lastSlope=1.0))
    with np.load(disk_npz) as data:
        centre = data["light_field"][2, 2]
    assert view.dtype == np.uint8 and len(rows) > 0
    np.testing.assert_array_equal(view, cv2.cvtColor(to_display(centre), cv2.COLOR_BGR2GRAY))


def test_detect_plot_into_a_new_folder(disk_npz, tmp_path, capsys):
    """--plot newdir/ (one input) is a folder, as --out newdir/ is."""
    plots, outs = str(tmp_path / "plots") + os.sep, str(tmp_path / "feats") + os.sep
    assert main(["detect", disk_npz, "--out", outs, "--plot", plots]) == 0
    assert os.listdir(tmp_path / "plots") == ["disks.png"]
    assert os.listdir(tmp_path / "feats") == ["disks.npz"]
    assert cv2.imread(str(tmp_path / "plots" / "disks.png")) is not None
    # A file name is kept as it is (its ending picks the image format).
    assert main(["detect", disk_npz, "--out", str(tmp_path / "one.npz"), "--plot",
                 str(tmp_path / "one.jpg")]) == 0
    assert cv2.imread(str(tmp_path / "one.jpg")) is not None


@pytest.mark.parametrize("kind", ["disks", "layers"])
@pytest.mark.parametrize("options, flag", [
    (["--size", "0", "0"], "--size"), (["--size", "32", "-4"], "--size"),
    (["--views", "0"], "--views"), (["--views", "-3"], "--views"), (["--noise", "-1"], "--noise"),
    (["--noise", "nan"], "--noise"), (["--noise", "inf"], "--noise")])
def test_synth_refuses_bad_sizes_and_noise(tmp_path, capsys, kind, options, flag):
    """Usage errors (exit 2) that name the flag and the values expected, before
    anything is made."""
    out = tmp_path / "lf.npz"
    with pytest.raises(SystemExit) as exit_:
        main(["synth", kind, "--out", str(out), *options])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and f"argument {flag}" in err and "expected" in err
    assert "Traceback" not in err and not out.exists()


@pytest.mark.parametrize("argv", [["match", "a.npz", "b.npz", "--ratio", "0"],
                                  ["match", "a.npz", "b.npz", "--threshold", "-1"],
                                  ["detect", "a.npz", "--workers", "0"],
                                  ["detect", "a.npz", "--first-slope", "nan"]])
def test_bad_option_values_are_usage_errors_naming_the_flag(capsys, argv):
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and f"argument {argv[-2]}" in err and "expected" in err


def test_every_detector_parameter_is_an_option(disk_npz, tmp_path):
    """The detector options come from liff.PARAMETERS: each create() keyword has its
    flag with create()'s default, and a value given on the command line reaches the
    detector (recorded in the output's metadata)."""
    import argparse

    from liff.cli import common

    parser = argparse.ArgumentParser()
    common.add_detector_options(parser)
    defaults = common.detector_parameters(parser.parse_args([]))
    assert defaults == {p.name: p.default for p in liff.PARAMETERS}
    given = {"nfeatures": 5, "nOctaveLayers": 4, "contrastThreshold": 0.03, "edgeThreshold": 8.0,
             "sigma": 1.5, "firstSlope": -1.5, "lastSlope": 1.5, "numSlopes": 7,
             "descriptorType": cv2.CV_8U, "rootSift": True, "firstOctave": 0}
    assert set(given) == set(defaults)
    argv = []
    for name, value in given.items():
        argv += [common.option_name(name)] if value is True else [common.option_name(name), str(value)]
    out = str(tmp_path / "f.npz")
    assert main(["detect", disk_npz, "--out", out] + argv) == 0
    features = load_features(out)
    assert features.meta["parameters"] == given
    assert features.descriptors.dtype == np.uint8


def hci_folder(root, disp_min, disp_max):
    """A 5x5-view HCI scene folder of blob layers at -1.8 and 1.6, with parameters.cfg."""
    shape = (5, 5, 96, 96)
    blobs = liff.synthetic.random_blob_layers([-1.8, 1.6], shape, blobs_per_layer=5, seed=2)
    lf = np.clip(liff.synthetic.render_disks(blobs, shape, profile="gaussian"), 0, 1)
    os.makedirs(root)
    for t in range(5):
        for s in range(5):
            view = np.round(lf[t, s] * 255).astype(np.uint8)
            cv2.imwrite(os.path.join(root, f"input_Cam{t * 5 + s:03d}.png"), cv2.merge([view] * 3))
    with open(os.path.join(root, "parameters.cfg"), "w") as f:
        f.write(f"[extrinsics]\nnum_cams_x = 5\nnum_cams_y = 5\n[meta]\ndisp_min = {disp_min}\n"
                f"disp_max = {disp_max}\n")
    return root


def test_detect_uses_a_readers_slope_range_unless_one_is_given(tmp_path, capsys):
    """An HCI scene's parameters.cfg range is used (and said); a range on the command
    line wins; without either the range is automatic. The line says which."""
    scene = hci_folder(str(tmp_path / "scene"), -2.0, 2.0)
    assert main(["detect", scene, "--out", str(tmp_path / "a.npz")]) == 0
    out = capsys.readouterr().out
    assert re.search(r"slopes -2\.00 to \+2\.00 \(parameters\.cfg\), \d+ slices searched of \d+ built", out)
    assert load_features(str(tmp_path / "a.npz")).meta["slopes_from"] == "parameters.cfg"
    assert main(["detect", scene, "--out", str(tmp_path / "b.npz"), "--first-slope", "-1",
                 "--last-slope", "1"]) == 0
    assert "slopes -1.00 to +1.00 (given)" in capsys.readouterr().out
    os.remove(os.path.join(scene, "parameters.cfg"))
    assert main(["detect", scene, "--out", str(tmp_path / "c.npz")]) == 0
    line = capsys.readouterr().out
    assert "(automatic)" in line
    first, last = map(float, re.search(r"slopes ([-+.\d]+) to ([-+.\d]+)", line).groups())
    assert first <= -1.5 and last >= 1.4


def test_detect_slope_bounds_given_win_each_end_and_a_rerun_keeps_its_output(tmp_path, capsys):
    """Each bound given wins at its end (infinite: automatic there), the other comes
    from parameters.cfg; the output of a run with a reader's range is kept on a re-run;
    a bound that is not a number is a usage error naming the flag."""
    scene = hci_folder(str(tmp_path / "scene"), -2.0, 2.0)
    assert main(["detect", scene, "--out", str(tmp_path / "a.npz"), "--first-slope", "-1"]) == 0
    assert re.search(r"slopes -1\.00 to \+[.\d]+ \(given \+ parameters\.cfg\)", capsys.readouterr().out)
    assert main(["detect", scene, "--out", str(tmp_path / "b.npz"), "--first-slope=-inf",
                 "--last-slope=inf"]) == 0
    assert "(automatic)" in capsys.readouterr().out
    assert load_features(str(tmp_path / "b.npz")).meta["parameters"]["firstSlope"] == -math.inf
    assert main(["detect", scene, "--out", str(tmp_path / "c.npz")]) == 0
    assert main(["detect", scene, "--out", str(tmp_path / "c.npz")]) == 0
    assert "skipped 1 input(s)" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exit_:
        main(["detect", scene, "--out", str(tmp_path / "d.npz"), "--first-slope", "nan"])
    assert exit_.value.code == 2 and "--first-slope" in capsys.readouterr().err


def test_detect_warns_in_one_line_when_a_given_range_cuts_the_scene(tmp_path, capsys):
    scene = hci_folder(str(tmp_path / "scene"), -2.0, 2.0)
    assert main(["detect", scene, "--out", str(tmp_path / "a.npz"), "--first-slope", "-0.5",
                 "--last-slope", "0.5"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    warned = [line for line in err if "warning:" in line]
    assert len(warned) == 1 and "sit at an end of the slope range [-0.5, 0.5]" in warned[0]
