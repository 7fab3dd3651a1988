"""What the command line says (issues 29 and 31, break tests left open): flags, not
Python names; warnings as one clean line; --lenslet values that cannot be a lenslet
size; a many-to-one match count that names the features of B it joins."""

from __future__ import annotations

import re

import numpy as np
import pytest
from test_subcommands_end_to_end import hci_folder

import liff
from lfhelpers import write_mat_v73
from liff.cli import main
from liff.io.formats import FORMATS


def eslf_image(path, n=5, size=64):
    lf = liff.synthetic.render_disks(liff.synthetic.paper_disks(n=8, shape=(n, n, size, size), seed=0),
                                     (n, n, size, size))
    liff.io.write_eslf(path, np.round(np.clip(lf, 0, 1) * 255).astype(np.uint8), n)
    return path


@pytest.mark.parametrize("value", ["1", "0", "-3", "x"])
def test_lenslet_refuses_what_cannot_be_a_lenslet_size(tmp_path, capsys, value):
    """Break test: --lenslet 1 read the image as a 1x1 light field (an ordinary image)
    and wrote its features; refused naming the flag, the value and what is expected,
    on the command line and on a --from-list line, before anything is read."""
    image = eslf_image(tmp_path / "a.eslf.png")
    out = tmp_path / "a.npz"
    with pytest.raises(SystemExit) as exit_:
        main(["detect", str(image), "--lenslet", value, "--out", str(out)])
    assert exit_.value.code == 2 and not out.exists()
    assert (f"argument --lenslet: {value}; expected a lenslet size N >= 2 pixels"
            in capsys.readouterr().err)
    todo = tmp_path / "todo.txt"
    todo.write_text(f"{image} --lenslet {value}\n")
    assert main(["detect", "--from-list", str(todo), "--out", str(tmp_path / "feats")]) == 1
    assert (f"{todo}, line 1: argument --lenslet: {value}; expected a lenslet size N >= 2"
            in capsys.readouterr().err)
    with pytest.raises(ValueError, match=r"lenslet size n = 1; expected a whole number of "
                                         r"pixels >= 2"):
        liff.io.read_eslf(image, 1)


def test_lenslet_refuses_an_image_too_small_for_8_lenslets_a_side(tmp_path, capsys):
    """Break test: a thumbnail (40x40 pixels) read with --lenslet 14 gave a light field
    of 2x2-pixel views. The command line asks at least 8 lenslets a side, as the size
    detection needs (8 a side is taken)."""
    import cv2

    image = eslf_image(tmp_path / "a.eslf.png", n=5, size=64)  # 320x320
    thumb = tmp_path / "thumb.eslf.png"
    cv2.imwrite(str(thumb), cv2.resize(cv2.imread(str(image), cv2.IMREAD_UNCHANGED), (40, 40)))
    assert main(["detect", str(thumb), "--lenslet", "14", "--out", str(tmp_path / "t.npz")]) == 1
    err = capsys.readouterr().err
    assert (f"{thumb}: image is 40x40: 2x2 lenslets of 14x14 pixels (--lenslet 14); expected "
            "at least 8 lenslets a side, an image of at least 112x112 pixels") in err
    assert not (tmp_path / "t.npz").exists()
    assert liff.io.read_eslf(thumb, 14).light_field.shape[2:4] == (2, 2)  # the API reads it
    assert main(["detect", str(thumb), "--lenslet", "5", "--out", str(tmp_path / "t.npz")]) == 0
    assert main(["pose", str(image), str(image), "--lenslet", "50", "--camera", "300", "0.04",
                 "3", "3"]) == 1  # (every command reads through the same check)
    assert "6x6 lenslets of 50x50 pixels (--lenslet 50)" in capsys.readouterr().err


def test_messages_name_flags_not_python_names(tmp_path, capsys):
    """Break test: 'liff.io.read_light_field lists the formats read', "format='mosaic'"
    and "read it with format='mat' (read_mat)" reached the command line."""
    missing = tmp_path / "absent.npz"
    unknown = tmp_path / "scene.xyz"
    unknown.write_bytes(b"x")
    v73 = tmp_path / "lf.h5"
    write_mat_v73(v73, {"LF": np.zeros((3, 3, 8, 8))})
    for path in (missing, unknown, v73):
        assert main(["detect", str(path), "--out", str(tmp_path / "o.npz")]) == 1
    err = capsys.readouterr().err
    formats = ", ".join(FORMATS)  # (the registry's order)
    assert f"{missing}: no such file or folder; expected a light field file or folder of a " \
           f"format liff reads ({formats})" in err
    assert "mosaic: only when named (--format mosaic)" in err
    assert "read it as a .mat file (--format mat)" in err
    assert not re.search(r"read_light_field|format='|read_mat", err)


def test_a_slope_range_warning_is_one_clean_line_naming_flags(tmp_path, capsys):
    """Break test: liff match printed Python's 'file.py:356: SlopeRangeWarning: ...' and
    the source line under it, with firstSlope= for the flag."""
    scene = hci_folder(str(tmp_path / "scene"), -2.0, 2.0)
    assert main(["match", scene, scene, "--first-slope", "-0.5", "--last-slope", "0.5"]) == 0
    err = capsys.readouterr().err
    warned = [line for line in err.splitlines() if "slope range" in line]
    assert len(warned) == 2  # one per input, each one line
    assert all(line.startswith("liff match: warning: ") and "--first-slope=" in line
               for line in warned)
    assert ".py:" not in err and "SlopeRangeWarning" not in err and "firstSlope" not in err


def test_a_many_to_one_match_count_names_the_features_of_b_it_joins(tmp_path, capsys):
    """Break test: 'putative matches: 271; inliers: 58' against a B of 13 features: the
    ratio test matches each feature of A to its nearest in B, so several share one."""
    lf = liff.synthetic.textured_layers((3, 3, 96, 96), seed=3).light_field
    np.save(tmp_path / "scene.npy", lf)
    a, b = str(tmp_path / "a.npz"), str(tmp_path / "b.npz")
    assert main(["detect", str(tmp_path / "scene.npy"), "--out", a]) == 0
    assert main(["detect", str(tmp_path / "scene.npy"), "--out", b, "--nfeatures", "12"]) == 0
    capsys.readouterr()
    assert main(["match", a, b, "--ratio", "1.0"]) == 0
    out = capsys.readouterr().out
    features_b = int(re.search(rf"{re.escape(b)}: (\d+) features", out).group(1))
    putative = int(re.search(r"putative matches: (\d+)", out).group(1))
    joined = re.search(r"many-to-one: the matches join (\d+) and the inliers (\d+) distinct "
                       rf"features of {re.escape(b)}", out)
    assert putative > features_b and joined
    assert int(joined.group(2)) <= int(joined.group(1)) <= features_b
    assert main(["match", a, a]) == 0  # one to one: nothing more said
    assert "many-to-one" not in capsys.readouterr().out


def test_detect_notes_and_reader_errors_name_flags(tmp_path, capsys):
    """Break test (break4): liff detect's warnings, as printed and in the manifest's
    notes, kept the readers' and the detector's Python names ("read it with bit_depth=8
    (--bit-depth 8)", "set firstSlope and lastSlope"), as did a --bit-depth too small
    for the data ("expected bit_depth >= 16") and the hloc refusals ("--overwrite
    (overwrite=True)"); liff match and liff colmap already named flags."""
    import csv

    lf = liff.synthetic.textured_layers((3, 3, 64, 64), seed=2).light_field.astype(np.float32)
    np.save(tmp_path / "f255.npy", lf * 255)  # floats in 0..255: an intensity warning
    np.save(tmp_path / "u12.npy", np.round(np.clip(lf, 0, 1) * 4095).astype(np.uint16))
    np.save(tmp_path / "u16.npy", np.round(np.clip(lf, 0, 1) * 65535).astype(np.uint16))
    out = tmp_path / "out"
    assert main(["detect", str(tmp_path / "f255.npy"), str(tmp_path / "u12.npy"),
                 "--out", str(out), "--manifest", str(tmp_path / "m.csv")]) == 0
    err = capsys.readouterr().err
    with open(tmp_path / "m.csv", newline="") as f:
        notes = "\n".join(row["notes"] for row in csv.DictReader(f))
    for text in (err, notes):
        assert "read it with --bit-depth 8, or scale it" in text
        assert "read it with --bit-depth 12, or scale it" in text
        assert not re.search(r"bit_depth|firstSlope|lastSlope|\(--bit-depth \d+\)", text)
    assert main(["detect", str(tmp_path / "u16.npy"), "--bit-depth", "8",
                 "--out", str(tmp_path / "u16.npz")]) == 1
    err = capsys.readouterr().err
    assert "expected --bit-depth >= 16" in err and "bit_depth" not in err
    feats, images = tmp_path / "h" / "f.h5", tmp_path / "h" / "images"
    images.mkdir(parents=True)
    (images / "u16.png").write_bytes(b"mine")
    assert main(["detect", str(tmp_path / "u16.npy"), "--out", str(tmp_path / "u16.npz"),
                 "--hloc", str(feats), "--hloc-images", str(images)]) == 1
    err = capsys.readouterr().err
    assert "or --overwrite to replace them" in err and "overwrite=True" not in err
    assert (images / "u16.png").read_bytes() == b"mine"


def feature_files(tmp_path):
    """Two liff detect feature files of one scene, and the scene (.npy)."""
    lf = liff.synthetic.textured_layers((3, 3, 96, 96), seed=3).light_field
    np.save(tmp_path / "scene.npy", lf)
    a, b = str(tmp_path / "a.npz"), str(tmp_path / "b.npz")
    assert main(["detect", str(tmp_path / "scene.npy"), "--out", a]) == 0
    assert main(["detect", str(tmp_path / "scene.npy"), "--out", b]) == 0
    return a, b, str(tmp_path / "scene.npy")


@pytest.mark.parametrize("command, flags, named", [
    (["match"], ["--contrast-threshold", "0.01", "--lenslet", "14"],
     "--lenslet, --contrast-threshold"),
    (["pose", "--camera", "300", "0.04", "47.5", "47.5"],
     ["--contrast-threshold", "0.01", "--key", "x"], "--key, --contrast-threshold"),
    (["colmap", "--database", "{tmp}/d.db", "--image-dir", "{tmp}/i"],
     ["--contrast-threshold", "0.01"], "--contrast-threshold"),
    (["match"], ["--preprocess", "--first-slope", "-1"], "--first-slope, --preprocess"),
    (["match"], ["--bit-depth", "12"], "--bit-depth"),
])
def test_options_for_light_fields_are_refused_when_the_inputs_are_feature_files(
        tmp_path, capsys, command, flags, named):
    """Break test 5: liff pose/match/colmap on two feature files took --contrast-threshold,
    --key, --lenslet and ran on the stored features, exit 0. With light-field inputs an
    option no input takes is an error; so it is here, naming the flags."""
    a, b, _ = feature_files(tmp_path)
    capsys.readouterr()
    args = [word.replace("{tmp}", str(tmp_path)) for word in command] + [a, b] + flags
    assert main(args) == 1
    err = capsys.readouterr().err
    assert (f"liff {command[0]}: option(s) {named} do not apply: the inputs are feature files "
            f"({a}, {b}), whose features are used as stored") in err, err
    assert not (tmp_path / "d.db").exists()


def test_options_for_light_fields_apply_when_one_input_is_a_light_field(tmp_path, capsys):
    """A feature file and a light field: the detector's options apply to the light field;
    a reader option that fits neither is named, with the feature file counted."""
    a, _, scene = feature_files(tmp_path)
    capsys.readouterr()
    assert main(["match", a, scene, "--contrast-threshold", "0.02"]) == 0
    assert main(["match", a, scene, "--lenslet", "14"]) == 1
    assert ("option(s) --lenslet do not apply to format 'npy' of any input (and 1 feature "
            "file(s), whose features are used as stored)") in capsys.readouterr().err


@pytest.mark.parametrize("flag, value, expected", [
    ("--keep-views", "0", "expected a whole number K >= 1 of centre views to keep on each axis"),
    ("--keep-views", "-1", "expected a whole number K >= 1 of centre views to keep on each axis"),
    ("--keep-views", "2.5", "expected a whole number K >= 1 of centre views to keep on each axis"),
    ("--bit-depth", "0", "expected a whole number of bits B from 1 to 16"),
    ("--bit-depth", "17", "expected a whole number of bits B from 1 to 16"),
])
def test_keep_views_and_bit_depth_are_checked_when_parsed(tmp_path, capsys, flag, value, expected):
    """Break test 5: --keep-views 0 and --bit-depth 17 passed parsing and --dry-run, and
    the run failed every input with 'centre_views: --keep-views (0, 0): T = 0'. Refused
    as --lenslet 0 is, naming the flag, the value and what is expected, on the command
    line and on a --from-list line."""
    image = eslf_image(tmp_path / "a.eslf.png")
    with pytest.raises(SystemExit) as exit_:
        main(["detect", str(image), flag, value, "--out", str(tmp_path / "f"), "--dry-run"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {flag}: {value}; {expected}" in err and "centre_views" not in err
    todo = tmp_path / "todo.txt"
    todo.write_text(f"{image} {flag} {value}\n")
    assert main(["detect", "--from-list", str(todo), "--out", str(tmp_path / "f"), "--dry-run"]) == 1
    assert f"{todo}, line 1: argument {flag}: {value}; {expected}" in capsys.readouterr().err
    assert not (tmp_path / "f").exists()
