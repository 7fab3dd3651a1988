"""Issue 12, section 1: the command line never loses data nor silently keeps stale
outputs. No output may be an input; several inputs need a folder; an output made with
other settings is redone (and said so); writes are atomic; missing folders are made."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import liff
from liff.cli import main
from liff.feature_file import load_features, read_meta


@pytest.fixture
def disks(tmp_path):
    """A small disk scene as `liff synth` writes it, in its own folder."""
    path = tmp_path / "d.npz"
    assert main(["synth", "disks", "--out", str(path), "--views", "3", "--size", "48", "48"]) == 0
    return path


def _out_is_input_cases(disks):
    folder = disks.parent
    os.symlink(disks.name, folder / "link.npz")
    os.link(disks, folder / "hard.npz")
    return {"default name (./d.npz)": [], "relative spelling": ["--out", "../" + folder.name + "/d.npz"],
            "symbolic link": ["--out", "link.npz"], "hard link": ["--out", "hard.npz"]}


@pytest.mark.parametrize("case", ["default name (./d.npz)", "relative spelling", "symbolic link",
                                  "hard link"])
def test_an_output_that_is_an_input_is_refused(disks, monkeypatch, capsys, case):
    argv = _out_is_input_cases(disks)[case]
    monkeypatch.chdir(disks.parent)
    before = disks.read_bytes()
    assert main(["detect", "d.npz", "--overwrite", *argv]) == 1
    err = capsys.readouterr().err
    assert "is the input d.npz" in err and "--out" in err
    assert disks.read_bytes() == before
    with np.load(disks) as data:  # still the light field, not features
        assert data["light_field"].shape == (3, 3, 48, 48)


def test_a_plot_or_output_inside_an_input_folder_is_refused(tmp_path, capsys):
    views = tmp_path / "views"
    assert main(["synth", "layers", "--out", str(views), "--format", "views", "--views", "3",
                 "--size", "32", "32"]) == 0
    files = sorted(os.listdir(views))
    assert main(["detect", str(views), "--out", str(views / "f.npz")]) == 1
    assert "inside the input folder" in capsys.readouterr().err
    assert main(["detect", str(views), "--out", str(tmp_path / "f.npz"), "--plot", str(views / "f.png")]) == 1
    assert "--plot" in capsys.readouterr().err
    assert sorted(os.listdir(views)) == files


def test_match_refuses_a_plot_over_an_input(disks, capsys):
    before = disks.read_bytes()
    assert main(["match", str(disks), str(disks), "--plot", str(disks)]) == 1
    assert "is the input" in capsys.readouterr().err and disks.read_bytes() == before


def test_several_inputs_with_a_file_name_for_out_create_nothing(disks, tmp_path, capsys):
    other = tmp_path / "e.npy"
    with np.load(disks) as data:
        np.save(other, data["light_field"])
    for out in ("x.npz", "x.png", "x.npy"):
        assert main(["detect", str(disks), str(other), "--out", str(tmp_path / out)]) == 1
        assert "expected a folder for --out" in capsys.readouterr().err
        assert not (tmp_path / out).exists()
    assert main(["detect", str(disks), str(other), "--out", str(tmp_path / "f"),
                 "--plot", str(tmp_path / "p.png")]) == 1
    assert "--plot" in capsys.readouterr().err and not (tmp_path / "f").exists()


def _detect(disks, out, *options):
    return main(["detect", str(disks), "--out", str(out), *options])


@pytest.mark.parametrize("options, differs", [
    (["--nfeatures", "10"], "nfeatures 0 -> 10"),
    (["--root-sift"], "rootSift False -> True"),
    (["--first-slope", "-0.5", "--last-slope", "0.5"], "firstSlope not given -> -0.5"),
    (["--preprocess"], "preprocess False -> True"),
    (["--key", "light_field"], "reader options not given -> --key light_field")])
def test_an_output_made_with_other_settings_is_redone_and_said(disks, tmp_path, capsys, options,
                                                               differs):
    out = tmp_path / "f.npz"
    assert _detect(disks, out) == 0
    assert _detect(disks, out) == 0
    assert "skipped 1 input(s) whose outputs exist, made with the same settings" in capsys.readouterr().out
    assert _detect(disks, out, *options) == 0
    printed = capsys.readouterr().out
    assert f"redoing {out}, out of date: " in printed and differs in printed
    assert "skipped" not in printed
    meta = read_meta(out)
    assert meta["liff_version"] == liff.__version__ and meta["source"] == str(disks)
    if "--nfeatures" in options:
        with np.load(disks) as data:
            expected = len(liff.LiFF.create(nfeatures=10).detect(data["light_field"]))
        assert meta["parameters"]["nfeatures"] == 10
        assert len(load_features(out).keypoints) == expected < 20  # ties with the 10th kept


@pytest.mark.parametrize("kind", ["file", "folder of views"])
def test_an_input_replaced_by_an_older_file_is_redone(tmp_path, capsys, kind):
    """cp -p, rsync -a and mv keep the replacement's older time: the output records the
    input's size and time and compares them for equality, not for 'newer'."""
    def write(seed):
        lf = liff.synthetic.textured_layers((3, 3, 48, 48), seed=seed).light_field
        lf = np.clip(lf * 255, 0, 255).astype(np.uint8)
        if kind == "file":
            path = tmp_path / "lf.npy"
            np.save(path, lf)
        else:
            path = tmp_path / "lf"
            liff.io.write_views(path, lf)
        return path

    path, out = write(0), tmp_path / "f.npz"
    assert _detect(path, out) == 0
    first = load_features(out)
    assert _detect(path, out) == 0 and "skipped 1 input(s)" in capsys.readouterr().out
    write(1)  # a different light field, then its time set back as cp -p would
    older = os.path.getmtime(out) - 3600
    for changed in ([path] if kind == "file" else list(path.iterdir())):
        os.utime(changed, (older, older))
    assert _detect(path, out) == 0
    assert "the input changed after the output was made" in capsys.readouterr().out
    assert not np.array_equal(load_features(out).descriptors, first.descriptors)
    assert _detect(path, out) == 0 and "skipped 1 input(s)" in capsys.readouterr().out


def test_an_input_changed_or_another_version_is_redone(disks, tmp_path, capsys):
    out = tmp_path / "f.npz"
    assert _detect(disks, out) == 0
    later = os.path.getmtime(out) + 10
    os.utime(disks, (later, later))
    assert _detect(disks, out) == 0
    assert "the input changed after the output was made" in capsys.readouterr().out
    features = load_features(out)
    features.meta["liff_version"] = "0.0.1"
    liff.feature_file.save_features(out, features)
    assert _detect(disks, out) == 0
    assert f"liff version 0.0.1 -> {liff.__version__}" in capsys.readouterr().out


def test_a_file_at_the_output_path_that_is_not_ours_is_refused(disks, tmp_path, capsys):
    out = tmp_path / "mine.npz"
    np.savez(out, my_data=np.arange(3))
    assert _detect(disks, out) == 1
    assert "not a liff feature file" in capsys.readouterr().err
    with np.load(out) as data:
        assert list(data["my_data"]) == [0, 1, 2]
    assert _detect(disks, out, "--overwrite") == 0 and read_meta(out) is not None


def test_a_failed_write_leaves_the_old_file_and_no_partial_one(disks, tmp_path, monkeypatch):
    out = tmp_path / "f.npz"
    assert _detect(disks, out) == 0
    before = out.read_bytes()

    def broken(path, features):
        with open(path, "wb") as f:
            f.write(b"PK\x03\x04 half a zip")
        raise OSError("disk full")

    monkeypatch.setattr("liff._tasks.save_features", broken)
    assert _detect(disks, out, "--nfeatures", "5") == 1
    assert out.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["d.npz", "f.npz"]


def test_a_run_killed_at_any_moment_leaves_no_truncated_output(tmp_path):
    """SIGKILL at several moments of `liff synth` + `liff detect` (a 9x9x192x192 light
    field): each output is absent or complete, never truncated."""
    script = ("from liff.cli import main; import sys; "
              "main(['synth', 'layers', '--out', sys.argv[1], '--views', '9', '--size', '192', '192']); "
              "main(['detect', sys.argv[1], '--out', sys.argv[2]])")
    for i, delay in enumerate((0.8, 1.6, 2.4, 3.2)):
        lf, features = tmp_path / f"lf{i}.npz", tmp_path / f"f{i}.npz"
        process = subprocess.Popen([sys.executable, "-c", script, str(lf), str(features)])
        time.sleep(delay)
        process.send_signal(signal.SIGKILL)
        process.wait()
        if lf.exists():
            with np.load(lf) as data:
                assert data["light_field"].shape == (9, 9, 192, 192)
        if features.exists():
            assert len(load_features(features).keypoints) > 0
    visible = [n for n in os.listdir(tmp_path) if not n.startswith(".")]
    assert all(n.startswith(("lf", "f")) for n in visible)


@pytest.mark.parametrize("argv", [
    ["synth", "disks", "--format", "eslf", "--out", "{t}/new/x.eslf.png"],
    ["synth", "disks", "--out", "{t}/nodir/x.npz"],
    ["synth", "layers", "--format", "views", "--out", "{t}/a/b/views"],
    ["synth", "layers", "--format", "mosaic", "--out", "{t}/a/m.png"],
    ["detect", "{d}", "--out", "{t}/nodir/f.npz", "--plot", "{t}/other/p.png"],
    ["match", "{d}", "{d}", "--plot", "{t}/nodir/m.png"],
    ["demo", "--out", "{t}/nodir/demo"]])
def test_every_subcommand_creates_missing_output_folders(disks, tmp_path, argv):
    small = ["--views", "3", "--size", "32", "32"] if argv[0] == "synth" else []
    argv = [a.format(t=tmp_path, d=disks) for a in argv] + small
    assert main(argv) == 0
    for value in argv:
        if str(tmp_path) in value and value != str(disks):
            assert os.path.exists(value), value


def test_synth_overwrite_replaces_a_views_folder_whole(tmp_path):
    """A 2x2-view light field written over a 3x3 one leaves no stale views behind."""
    out = tmp_path / "v"
    base = ["synth", "layers", "--format", "views", "--out", str(out), "--size", "32", "32"]
    assert main(base + ["--views", "3"]) == 0
    assert main(base + ["--views", "2", "--overwrite"]) == 0
    assert len(os.listdir(out)) == 4
    assert liff.io.read_light_field(out).light_field.shape[:2] == (2, 2)
    assert json.loads("[]") == [n for n in os.listdir(tmp_path) if n.startswith(".")]


def test_a_foreign_file_at_the_plot_path_is_refused_and_our_plot_is_redone(disks, tmp_path, capsys):
    notes = tmp_path / "notes.png"
    notes.write_text("important notes")
    out = tmp_path / "f.npz"
    assert main(["detect", str(disks), "--out", str(out), "--plot", str(notes)]) == 1
    err = capsys.readouterr().err
    assert "notes.png: exists and is not the plot of" in err and "--overwrite" in err
    assert notes.read_text() == "important notes" and not out.exists()
    plot = tmp_path / "p.png"
    assert main(["detect", str(disks), "--out", str(out), "--plot", str(plot)]) == 0
    assert main(["detect", str(disks), "--out", str(out), "--plot", str(plot), "--nfeatures", "5"]) == 0
    assert "redoing" in capsys.readouterr().out and plot.exists()


@pytest.mark.parametrize("target", ["input", "output", "foreign"])
def test_a_manifest_over_an_input_an_output_or_a_foreign_file_is_refused(disks, tmp_path, capsys,
                                                                         target):
    out = tmp_path / "f.npz"
    foreign = tmp_path / "precious.csv"
    foreign.write_text("precious")
    manifest = {"input": disks, "output": out, "foreign": foreign}[target]
    before = manifest.read_bytes() if manifest.exists() else None
    assert main(["detect", str(disks), "--out", str(out), "--manifest", str(manifest)]) == 1
    assert "--manifest" in capsys.readouterr().err
    assert (manifest.read_bytes() if manifest.exists() else None) == before
    # a manifest of an earlier run is ours to replace
    run_manifest = tmp_path / "run.csv"
    assert main(["detect", str(disks), "--out", str(out), "--manifest", str(run_manifest)]) == 0
    assert main(["detect", str(disks), "--out", str(out), "--manifest", str(run_manifest)]) == 0
    assert "kept" in run_manifest.read_text()


def test_sfm_refuses_a_workspace_in_an_input_folder(tmp_path, capsys):
    poses = tmp_path / "poses"
    assert main(["synth", "poses", "--out", str(poses), "--views", "3", "--size", "48", "64",
                 "--poses", "2"]) == 0
    before = sorted(os.listdir(poses))
    assert main(["sfm", str(poses), "--workspace", str(poses)]) == 1
    assert "inside the input folder" in capsys.readouterr().err
    assert sorted(os.listdir(poses)) == before


def test_detect_writes_nothing_inside_a_folder_of_light_fields_given(disks, tmp_path, capsys):
    """A folder of light-field files is an input too: outputs, plots and manifests
    inside it would be read as light fields by the next run over the folder."""
    folder = tmp_path / "lfs"
    folder.mkdir()
    os.replace(disks, folder / disks.name)
    for argv, flag in ((["--out", str(folder)], "--out"), (["--out", str(folder / "f")], "--out"),
                       (["--out", str(tmp_path / "o"), "--manifest", str(folder / "m.csv")],
                        "--manifest")):
        before = sorted(os.listdir(folder))
        assert main(["detect", str(folder), *argv]) == 1
        err = capsys.readouterr().err
        assert ("inside the input folder" in err or "is the input" in err) and flag in err
        assert sorted(os.listdir(folder)) == before


@pytest.mark.parametrize("overwrite", [[], ["--overwrite"]])
@pytest.mark.parametrize("option", ["--out", "--manifest", "--plot", "input"])
def test_a_fifo_in_place_of_a_file_is_refused_at_once(disks, tmp_path, capsys, option, overwrite):
    # opening a FIFO to check it (or to read it) blocked liff forever
    from lfhelpers import Fifo
    name = {"--out": "f.npz", "--manifest": "m.csv", "--plot": "p.png", "input": "in.npz"}[option]
    with Fifo(tmp_path / name) as fifo:
        argv = ["detect", str(disks), "--out", str(tmp_path / "out.npz"), *overwrite]
        if option == "input":
            argv[1] = fifo.path
        elif option == "--out":
            argv[3] = fifo.path
        else:
            argv += [option, fifo.path]
        assert main(argv) == 1
    err = capsys.readouterr().err
    assert f"{fifo.path}: is a FIFO" in err, err
    assert fifo.opened == 0
    assert os.path.exists(fifo.path) and not os.path.isfile(fifo.path)  # left as it was
    assert not os.path.exists(tmp_path / "out.npz") or option == "--plot"


@pytest.mark.parametrize("change", ["zeroed descriptors", "one keypoint moved", "no digest"])
def test_an_output_whose_arrays_were_changed_is_redone(disks, tmp_path, capsys, change):
    """Issue 32: the decision to keep an output read only its meta, so a file whose
    descriptors were zeroed was kept as "made with the same settings"."""
    out = tmp_path / "f.npz"
    assert _detect(disks, out) == 0
    written = load_features(out)
    with np.load(out) as data:
        arrays = {name: data[name] for name in data.files}
    if change == "zeroed descriptors":
        arrays["descriptors"] = np.zeros_like(arrays["descriptors"])
    elif change == "one keypoint moved":
        arrays["keypoints"][0, 0] += 1
    else:
        del arrays["digest"]
    np.savez_compressed(out, **arrays)  # meta intact
    if change != "no digest":
        with pytest.raises(ValueError, match="do not match the digest written with them"):
            load_features(out)
    capsys.readouterr()
    assert _detect(disks, out) == 0
    printed = capsys.readouterr().out
    assert f"redoing {out}, out of date: " in printed and "skipped" not in printed
    assert ("no content digest" if change == "no digest" else "do not match the digest") in printed
    np.testing.assert_array_equal(load_features(out).descriptors, written.descriptors)
    assert _detect(disks, out) == 0 and "skipped 1 input(s)" in capsys.readouterr().out
