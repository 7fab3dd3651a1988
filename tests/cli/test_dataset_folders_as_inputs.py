"""Datasets as they sit on disk (issue 31): folders expanded entry by entry by names and
content (liff.io.layout), ``liff detect --dry-run``, reader options per input (applied
where they fit, per line of a list file, said in the manifest), a manifest row for a
failing input, flags in messages."""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np
import pytest

import liff
from liff.cli import main
from liff.cli.inputs import expand
from liff.io.layout import walk


def read_manifest(folder: Path) -> list:
    (manifest,) = [p for p in folder.iterdir() if p.name.startswith("manifest-")]
    with open(manifest, newline="") as f:
        return list(csv.DictReader(f))


def lenslet_image(path: Path, n: int = 5, size: int = 32, seed: int = 0) -> Path:
    """A lenslet (ESLF) image as the Stanford archive stores one, under ``path``'s name."""
    lf = liff.synthetic.render_disks(liff.synthetic.paper_disks(n=8, shape=(n, n, size, size),
                                                                seed=seed), (n, n, size, size))
    path.parent.mkdir(parents=True, exist_ok=True)
    liff.io.write_eslf(path, np.round(np.clip(lf, 0, 1) * 255).astype(np.uint8), n)
    return path


def light_field_npz(path: Path, shape=(3, 3, 24, 24), key="light_field") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, **{key: liff.synthetic.textured_layers(shape, seed=1).light_field})
    return path


def views_folder(folder: Path, shape=(3, 3, 16, 16)) -> Path:
    liff.io.write_views(folder, np.zeros(shape, np.uint8))
    return folder


def list_refused(todo: Path, text: str, match: str) -> None:
    """Asserts that the list file ``todo`` holding ``text`` is refused with ``match``."""
    todo.write_text(text)
    with pytest.raises(ValueError, match=match):
        expand([], {}, str(todo))


def taken(entries) -> list:
    return [(os.path.basename(e.path), e.format) for e in entries if e.is_input]


@pytest.mark.parametrize("n, size", [(5, 24), (7, 40)])
def test_a_stanford_style_folder_of_lenslet_images_with_their_real_names(tmp_path, n, size):
    """The archive's *_eslf.png, *.eslf.png and plain names, with liff synth's sidecars
    beside them: each image is a lenslet image, no sidecar is an input."""
    names = ["IMG_1085_eslf.png", "flowers_plants_12_eslf.png", "occlusions_3.eslf.png",
             "IMG_2184.png", "2016-06-12_10-15-35.png"]
    for i, name in enumerate(names):
        lenslet_image(tmp_path / "lytro" / name, n, size, seed=i)
    np.save(tmp_path / "lytro" / "IMG_1085_eslf.slopes.npy", np.zeros((size, size)))
    (tmp_path / "lytro" / "IMG_1085_eslf.png.truth.json").write_text("{}")
    entries = walk(str(tmp_path / "lytro"))
    assert taken(entries) == [(name, "eslf") for name in sorted(names)]
    assert sorted(os.path.basename(e.path) for e in entries if not e.is_input) == [
        "IMG_1085_eslf.png.truth.json", "IMG_1085_eslf.slopes.npy"]
    # the README's example, --keep-views applied to every input (each is a lenslet image)
    out = tmp_path / "features"
    assert main(["detect", str(tmp_path / "lytro"), "--keep-views", str(n - 2), "--out", str(out),
                 "--lenslet", str(n), "--contrast-threshold", "0.01"]) == 0
    rows = read_manifest(out)
    assert [r["status"] for r in rows] == ["done"] * len(names)
    assert {r["reader_options"] for r in rows} == {f"--lenslet {n} --keep-views {n - 2}"}
    assert {r["format"] for r in rows} == {"eslf"}


def make_dataset(root: Path, size: int) -> dict:
    """A dataset folder of every kind: a lenslet PNG at the top, a folder of views, an
    HCI scene (with its ground truth and a mask image), .npz files, a .npy that is a slope
    map, feature files and a manifest of an earlier run."""
    lenslet_image(root / "overview.png", 5, size)
    views_folder(root / "scene_a", (3, 3, size, size))
    hci = root / "hci" / "boxes"
    for i in range(9):
        liff.io.write_views(hci, np.zeros((1, 1, size, size, 3), np.uint8),
                            pattern=f"input_Cam{i:03d}.png")
    liff.io.write_pfm(hci / "gt_disp_lowres.pfm", np.zeros((size, size), np.float32))
    liff.io.write_views(hci, np.zeros((1, 1, size, size), np.uint8), pattern="valid_mask.png")
    light_field_npz(root / "scene_b.npz", (3, 3, size, size))
    light_field_npz(root / "more" / "scene_c.npz", (5, 5, size, size), key="lf")
    np.save(root / "more" / "scene_c.slopes.npy", np.zeros((size, size)))
    np.save(root / "more" / "depth.npy", np.zeros((size, size)))  # no 4-D array: not an input
    feats = root / "features"
    feats.mkdir()
    np.savez(feats / "scene_b.npz", keypoints=np.zeros((2, 6)), descriptors=np.zeros((2, 128)))
    (feats / "manifest-20260101-000000.csv").write_text("input,output\n")
    return {"inputs": [("boxes", "hci"), ("scene_c.npz", "npz"), ("overview.png", "eslf"),
                       ("scene_a", "views"), ("scene_b.npz", "npz")],
            "left_out": ["depth.npy", "gt_disp_lowres.pfm", "manifest-20260101-000000.csv",
                         "scene_b.npz", "scene_c.slopes.npy"]}


@pytest.mark.parametrize("size", [16, 28])
def test_a_mixed_dataset_folder_is_expanded_entry_by_entry(tmp_path, size):
    """Issue 31: one lenslet PNG at the top made the whole folder 'one folder of views'."""
    expected = make_dataset(tmp_path / "data", size)
    inputs, left_out = expand([str(tmp_path / "data")], {})
    assert [(os.path.basename(i.path), i.format) for i in inputs] == expected["inputs"]
    assert sorted(os.path.basename(e.path) for e in left_out) == expected["left_out"]
    # feature files are inputs where liff takes them (colmap, sfm)
    inputs, _ = expand([str(tmp_path / "data")], {}, features=True)
    assert "features" in {os.path.basename(os.path.dirname(i.path)) for i in inputs}


def test_dry_run_lists_what_would_be_read_as_what(tmp_path, capsys):
    make_dataset(tmp_path / "data", 16)
    assert main(["detect", str(tmp_path / "data"), "--dry-run", "--key", "lf",
                 "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert f"{tmp_path / 'data' / 'overview.png'}: eslf (lenslet image" in out
    assert f"{tmp_path / 'data' / 'scene_a'}: views (views: 9 images" in out
    assert f"{tmp_path / 'data' / 'more' / 'scene_c.npz'}: npz (named *.npz); --key lf" in out
    assert f"{tmp_path / 'data' / 'features' / 'scene_b.npz'}: not an input: a npz file holding " \
           "no 4-D or 5-D array" in out
    assert "scene_c.slopes.npy: not an input: written by liff" in out
    assert "gt_disp_lowres.pfm: not an input: not a light field name" in out
    assert "5 input(s) would be read; 5 file(s) left out; nothing was read or written" in out
    assert not (tmp_path / "out").exists()


def test_a_list_mixing_formats_carries_options_per_line(tmp_path):
    eslf = lenslet_image(tmp_path / "IMG_0001.eslf.png")
    plain = lenslet_image(tmp_path / "lytro" / "IMG_0002.png", 7, 24)
    npz = light_field_npz(tmp_path / "a.npz", key="lf")
    todo = tmp_path / "todo.txt"
    todo.write_text(f"# mixed\n{eslf} --lenslet 5 --keep-views 3\n{npz}\n"
                    f"'{plain}' --lenslet 7   # quoted, with a comment\n")
    inputs, _ = expand([], {"key": "lf", "bit_depth": 8}, str(todo))
    assert [(i.format, i.options) for i in inputs] == [
        ("eslf", {"n": 5, "keep": 3, "bit_depth": 8, "format": "eslf"}),
        ("npz", {"key": "lf", "bit_depth": 8, "format": "npz"}),
        ("eslf", {"n": 7, "bit_depth": 8, "format": "eslf"})]
    list_refused(todo, f"{npz} --lenslet 14\n",
                 rf"{todo}: {npz}: --lenslet do not apply to format 'npz'; "
                 r"expected --key, --bit-depth")
    list_refused(todo, f"{npz} --lenslet fourteen\n",
                 rf"{todo}, line 1: .*--lenslet.*fourteen")
    list_refused(todo, f"{npz} --n 14\n",
                 rf"{todo}, line 1: --n 14 is not a reader option; "
                 r"expected --format, --grid, --lenslet")


def test_options_apply_where_they_fit_and_the_manifest_says_where(tmp_path, capsys):
    lenslet_image(tmp_path / "data" / "IMG_0001_eslf.png")
    light_field_npz(tmp_path / "data" / "b.npz", key="lf")
    todo = tmp_path / "todo.txt"
    todo.write_text(f"{tmp_path / 'data' / 'IMG_0001_eslf.png'}\n{tmp_path / 'data' / 'b.npz'}\n")
    out = tmp_path / "out"
    assert main(["detect", "--from-list", str(todo), "--lenslet", "5", "--key", "lf",
                 "--out", str(out)]) == 0
    rows = {os.path.basename(r["input"]): r for r in read_manifest(out)}
    assert rows["IMG_0001_eslf.png"]["reader_options"] == "--lenslet 5"
    assert rows["b.npz"]["reader_options"] == "--key lf"
    assert rows["b.npz"]["format"] == "npz" and rows["IMG_0001_eslf.png"]["format"] == "eslf"
    # an option that fits no input is an error naming its flag and the formats it fits
    assert main(["detect", str(tmp_path / "data" / "b.npz"), "--keep-views", "3",
                 "--out", str(tmp_path / "x.npz")]) == 1
    err = capsys.readouterr().err
    assert "option(s) --keep-views do not apply to format 'npz' of any input (--keep-views: " \
           "eslf); expected --key, --bit-depth" in err and "keep" not in err.replace("--keep-views", "")


def test_the_only_input_failing_has_its_manifest_row_naming_the_flag(tmp_path, capsys):
    """Issue 31: one lenslet image whose size cannot be told, in a folder: the run fails
    with a manifest row whose error names --lenslet, not the keyword n."""
    folder = tmp_path / "lytro"
    folder.mkdir()
    rng = np.random.default_rng(0)
    liff.io.write_views(folder, rng.integers(0, 255, (1, 1, 45, 40), np.uint8),
                        pattern="IMG_0001.png")  # noise: no lenslets to see
    out = tmp_path / "features"
    assert main(["detect", str(folder), "--out", str(out)]) == 1
    (row,) = read_manifest(out)
    assert row["status"] == "failed" and row["format"] == "eslf"
    assert "cannot tell the lenslet size" in row["error"] and "(--lenslet N)" in row["error"]
    assert "n=" not in row["error"]
    assert "(--lenslet N)" in capsys.readouterr().err


@pytest.mark.parametrize("pattern, message", [
    ("(", "--pattern '(' is not a regular expression (missing ), unterminated subpattern"),
    ("view", "--pattern view has groups []; expected named groups (?P<t>...)"),
])
def test_a_pattern_that_is_no_views_pattern_is_an_error_naming_the_flag(tmp_path, capsys,
                                                                        pattern, message):
    """Break test of issue 31: --pattern '(' printed re.error's traceback."""
    views_folder(tmp_path / "scene")
    assert main(["detect", str(tmp_path / "scene"), "--pattern", pattern, "--dry-run"]) == 1
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and "re.error" not in err


@pytest.mark.parametrize("where", ["scene", "."])
def test_a_pattern_matching_no_view_of_a_views_folder_says_so(tmp_path, capsys, where):
    """The folder's views were taken as lenslet images when --pattern matched none."""
    views_folder(tmp_path / "scene", (2, 3, 8, 8))
    given = str(tmp_path / where)
    assert main(["detect", given, "--pattern", r"x_(?P<t>\d+)_(?P<s>\d+)\.png", "--dry-run"]) == 1
    err = capsys.readouterr().err
    assert f"no file in {tmp_path / 'scene'} matches --pattern 'x_(?P<t>\\d+)_(?P<s>\\d+)\\.png'" \
           in err and "eslf" not in err
    assert main(["detect", given, "--pattern", r"view_(?P<t>\d+)_(?P<s>\d+)\.png",
                 "--dry-run"]) == 0
    assert f"{tmp_path / 'scene'}: views (views: 6 images" in capsys.readouterr().out


@pytest.mark.parametrize("command", ["match", "pose"])
def test_pose_and_match_apply_each_option_where_it_fits(tmp_path, capsys, command):
    """Break test of issue 31: each input of liff pose/match was resolved alone, so
    --lenslet, which the lenslet image takes, was refused for the npz."""
    eslf = lenslet_image(tmp_path / "IMG_0001.eslf.png", 5, 32)
    npz = light_field_npz(tmp_path / "a.npz", key="lf")
    camera = ["--camera", "300", "0.04", "15.5", "15.5"] if command == "pose" else []
    main([command, str(eslf), str(npz), "--lenslet", "5", "--key", "lf"] + camera)
    captured = capsys.readouterr()
    assert "do not apply" not in captured.err and "no array" not in captured.err
    if command == "match":
        assert f"{eslf}: " in captured.out and " features; " in captured.out
    # an option no input takes is still refused, naming its flag
    assert main([command, str(eslf), str(npz), "--grid", "3", "3"] + camera) == 1
    assert "option(s) --grid do not apply to format 'eslf', 'npz' of any input" \
           in capsys.readouterr().err


def test_warnings_while_reading_are_notes_and_one_clean_line(tmp_path, capsys):
    """Break test of issue 31: a MissingViewsWarning raised while reading escaped as a
    raw Python warning and missed the manifest's notes."""
    import warnings

    scene = tmp_path / "scene"
    liff.io.write_views(scene, liff.synthetic.textured_layers((3, 3, 64, 64), seed=2)
                        .light_field.astype(np.float32).clip(0, 1).__mul__(255).astype(np.uint8))
    (scene / "view_02_02.png").unlink()
    out = tmp_path / "out"
    with warnings.catch_warnings(record=True) as escaped:
        warnings.simplefilter("always")
        assert main(["detect", str(scene), "--grid", "3", "3", "--out", str(out / "f.npz"),
                     "--manifest", str(tmp_path / "m.csv")]) == 0
    assert not [w for w in escaped if issubclass(w.category, liff.LiffWarning)]
    with open(tmp_path / "m.csv", newline="") as f:
        (row,) = list(csv.DictReader(f))
    assert "1 of 9 views missing" in row["notes"]
    err = capsys.readouterr().err
    assert f"liff detect: {scene}: warning: {scene}: 1 of 9 views missing" in err


def test_a_quoted_glob_follows_the_rules_of_a_folder_walk(tmp_path, capsys):
    """Break test of issue 31: 'lyt/*' took liff's sidecars and feature files as inputs,
    followed a link back up (selfloop -> .), and 'data/**/*.png' took the views of a
    folder as lenslet images."""
    data = tmp_path / "data"
    lenslet_image(data / "IMG_0001.png")
    np.save(data / "IMG_0001.png.slopes.npy", np.zeros((6, 6)))
    (data / "IMG_0001.png.truth.json").write_text("{}")
    np.savez(data / "kp.npz", keypoints=np.zeros((1, 6)), descriptors=np.zeros((1, 4)))
    views_folder(data / "scene")
    os.symlink(".", data / "selfloop")
    inputs, left_out = expand([str(data / "*")], {})
    assert [(os.path.relpath(i.path, data), i.format) for i in inputs] == [
        ("IMG_0001.png", "eslf"), ("scene", "views")]
    assert sorted(os.path.basename(e.path) for e in left_out) == [
        "IMG_0001.png.slopes.npy", "IMG_0001.png.truth.json", "kp.npz", "selfloop"]
    inputs, left_out = expand([str(data / "**" / "*.png")], {})
    assert [(os.path.relpath(i.path, data), i.format) for i in inputs] == [
        ("IMG_0001.png", "eslf"), ("scene", "views")]
    # a pattern that matches only what is not a light field says so
    assert main(["detect", str(data / "*.npy"), "--dry-run"]) == 1
    assert "none of the 1 path(s) it matches is a light field" in capsys.readouterr().err


def test_every_list_line_is_split_as_a_shell_would(tmp_path):
    """Break test of issue 31: a line without ' --' kept its quotes and a trailing
    comment as part of the path; a name holding ' --' could not be listed."""
    odd = light_field_npz(tmp_path / "my scan --final.npz")
    plain = light_field_npz(tmp_path / "scene b.npz")
    todo = tmp_path / "todo.txt"
    todo.write_text(f"'{plain}'\n{tmp_path / 'scene'}\\ b.npz   # a comment\n"
                    f"  # indented comment\n\n'{odd}'\n\"{odd}\" --key light_field\n")
    (tmp_path / "scene").mkdir()
    inputs, _ = expand([], {}, str(todo))
    assert [(i.path, i.options) for i in inputs] == [
        (str(plain), {"format": "npz"}), (str(odd), {"format": "npz"})]
    list_refused(todo, f"{plain}\n",
                 rf"{todo}, line 1: .* are 2 words; expected a path "
                 r"\(quoted if it holds spaces\)")  # unquoted spaces: two words
    list_refused(todo, f"'{plain}\n",
                 rf"{todo}, line 1: No closing quotation")


def test_a_light_field_toolbox_folder_takes_only_the_mat_files_holding_a_light_field(tmp_path):
    """Break test of issue 31: CalInfo.mat and the toolbox's other non-light-field .mat
    files (v5 and v7.3) were taken as inputs and became failed rows. A .mat is an input
    only when its header holds a 4-D or 5-D array (or a struct with a field LF)."""
    import scipy.io

    from lfhelpers import write_mat_v73

    folder = tmp_path / "toolbox"
    folder.mkdir()
    H = np.eye(5)
    scipy.io.savemat(folder / "CalInfo.mat", {"EstCamIntrinsicsH": H, "CalInfo": {
        "EstCamDistortionV": np.zeros(5), "LensletGridModel": {"HSpacing": 14.0}}})
    scipy.io.savemat(folder / "CheckerboardCorners.mat", {"CheckerboardCorners": np.zeros((3, 4, 2))},
                     do_compression=True)
    write_mat_v73(folder / "CalInfo73.mat", {"EstCamIntrinsicsH": H, "RectOptions": {"Precision": 1.0}})
    scipy.io.savemat(folder / "IMG_0001__Decoded.mat", {
        "LF": np.zeros((3, 3, 8, 8, 4), np.uint16), "RectOptions": {"RectCamIntrinsicsH": H}},
        do_compression=True)
    write_mat_v73(folder / "IMG_0002__Decoded.mat", {"LF": np.zeros((3, 3, 8, 8, 4), np.uint16)})
    scipy.io.savemat(folder / "hci_struct.mat", {"LF": {"LF": np.zeros((3, 3, 8, 8, 3)),
                                                         "disp_lowres": np.zeros((8, 8))}})
    entries = walk(str(folder))
    assert taken(entries) == [("IMG_0001__Decoded.mat", "mat"), ("IMG_0002__Decoded.mat", "mat"),
                              ("hci_struct.mat", "mat")]
    left_out = {os.path.basename(e.path): e.why for e in entries if not e.is_input}
    assert sorted(left_out) == ["CalInfo.mat", "CalInfo73.mat", "CheckerboardCorners.mat"]
    assert all("holding no 4-D or 5-D array" in why for why in left_out.values())


def test_a_mat_files_header_is_read_without_its_data(tmp_path):
    """The check reads headers only: of an 8 MB compressed variable, no more than the
    compressed pieces (16 KiB each) that inflate to its first 64 KiB."""
    import scipy.io

    from liff.io import _matv5

    path = tmp_path / "big.mat"
    rng = np.random.default_rng(0)
    scipy.io.savemat(path, {"LF": rng.random((10, 10, 100, 100, 1)), "other": np.zeros((2, 2))},
                     do_compression=True)

    class Counting:
        def __init__(self, f):
            self.f, self.read_bytes = f, 0

        def read(self, n=-1):
            data = self.f.read(n)
            self.read_bytes += len(data)
            return data

        def __getattr__(self, name):
            return getattr(self.f, name)

    with open(path, "rb") as f:
        counting = Counting(f)
        headers = _matv5.variable_headers(counting)
    assert [(name, dims) for name, dims, *_ in headers] == [("LF", (10, 10, 100, 100, 1)),
                                                            ("other", (2, 2))]
    assert counting.read_bytes < 2 * _matv5.HEADER_BYTES < os.path.getsize(path) // 50


@pytest.mark.parametrize("case", ["collision", "output is input", "file for many", "manifest",
                                  "hloc images alone"])
def test_dry_run_refuses_exactly_what_the_run_refuses(tmp_path, capsys, monkeypatch, case):
    """Break test of issue 31: two inputs that write one output were listed by --dry-run
    (exit 0) while the run refused them; one function (liff.cli.detect.checked_plan)
    now decides both."""
    monkeypatch.chdir(tmp_path)
    a = light_field_npz(tmp_path / "data" / "x" / "scene.npz")
    b = light_field_npz(tmp_path / "data" / "y" / "scene.npz")
    (tmp_path / "notes.csv").write_text("mine\n")
    argv = {"collision": [str(tmp_path / "data"), "--out", "feats"],
            "output is input": ["data/x/scene.npz", "--out", str(a)],
            "file for many": [str(a), str(b), "--out", "one.npz"],
            "manifest": [str(a), "--out", "f.npz", "--manifest", "notes.csv"],
            "hloc images alone": [str(a), "--out", "f.npz", "--hloc-images", "imgs"]}[case]
    assert main(["detect", *argv, "--dry-run"]) == 1
    dry = capsys.readouterr().err
    assert main(["detect", *argv]) == 1
    real = capsys.readouterr().err
    assert dry == real and dry.startswith("liff detect: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data", "notes.csv"]
    assert (tmp_path / "notes.csv").read_text() == "mine\n"


def test_a_list_written_with_a_byte_order_mark_and_crlf_reads_its_first_path(tmp_path):
    """Break test (break4): a list saved by Windows Notepad (UTF-8 with a byte order
    mark, CR LF line ends) failed its first line: '\\ufeffa.npz: no such file or folder',
    with the mark invisible in the message."""
    a = light_field_npz(tmp_path / "a.npz")
    b = light_field_npz(tmp_path / "b.npz")
    todo = tmp_path / "todo.txt"
    todo.write_bytes(b"\xef\xbb\xbf" + f"{a}\r\n{b} --key light_field\r\n".encode())
    inputs, _ = expand([], {}, from_list=str(todo))
    assert [item.path for item in inputs] == [str(a), str(b)]


def test_dry_run_says_which_given_paths_do_not_exist(tmp_path, capsys):
    """Break test (break4): a path on the command line or in a list that does not exist
    was listed by --dry-run as 'told when read (given)', counted among the inputs that
    would be read, with exit status 0; the run then failed it."""
    a = light_field_npz(tmp_path / "a.npz")
    todo = tmp_path / "todo.txt"
    todo.write_text(f"{tmp_path / 'gone.npz'}\n")
    argv = ["detect", str(a), str(tmp_path / "absent.npz"), "--from-list", str(todo),
            "--out", str(tmp_path / "out"), "--dry-run"]
    assert main(argv) == 1
    out = capsys.readouterr().out
    assert f"{tmp_path / 'absent.npz'}: no such file or folder; the run would fail it" in out
    assert f"{tmp_path / 'gone.npz'}: no such file or folder; the run would fail it" in out
    assert f"{a}: npz" in out and "told when read" not in out
    assert "1 input(s) would be read, 2 missing;" in out
    assert not (tmp_path / "out").exists()
    assert main(argv[:-1]) == 1  # the run fails them (and does the rest)
    assert (tmp_path / "out" / "a.npz").exists()


def test_a_mosaic_in_a_dataset_folder_is_a_failed_row_not_zero_features(tmp_path, capsys):
    """Break test 5: a mosaic image (liff synth --format mosaic) among a dataset's files is
    taken as a lenslet image (docs/INPUTS.md, folder walk) and must then be refused, not
    read with a lenslet size only its column profile suggests (19, not dividing it) and
    reported done with 0 features."""
    folder, out = tmp_path / "ds", tmp_path / "dsf"
    assert main(["synth", "disks", "--views", "5", "--size", "96", "128", "--format", "mosaic",
                 "--out", str(folder / "mos.png")]) == 0
    assert main(["detect", str(folder), "--out", str(out)]) == 1
    (row,) = read_manifest(out)
    assert row["status"] == "failed" and row["format"] == "eslf", row
    assert "cannot tell the lenslet size" in row["error"] and "(--lenslet N)" in row["error"]
    assert "along both rows and columns" in row["error"]
    err = capsys.readouterr().err
    assert "mos.png" in err and "failed" in err and "0 features" not in err
