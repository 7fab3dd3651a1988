"""cv2.FileStorage persistence: save/read/write round trips and validation on read."""

import json
import math
import pathlib
import subprocess
import sys
import textwrap

import cv2
import numpy as np
import pytest

import liff

CUSTOM = dict(
    nfeatures=17, nOctaveLayers=4, contrastThreshold=0.031, edgeThreshold=7.5, sigma=1.3,
    firstSlope=-0.75, lastSlope=1.25, numSlopes=9, descriptorType=cv2.CV_8U, rootSift=True,
)
EXTENSIONS = ["yml", "yaml", "xml", "json"]


def params(d):
    return (
        d.getNFeatures(), d.getNOctaveLayers(), d.getContrastThreshold(), d.getEdgeThreshold(),
        d.getSigma(), d.getFirstSlope(), d.getLastSlope(), d.getNumSlopes(),
        d.getDescriptorType(), d.getRootSift(),
    )


@pytest.fixture
def custom():
    return liff.LiFF.create(**CUSTOM)


@pytest.mark.parametrize("ext", EXTENSIONS)
@pytest.mark.parametrize("as_path", [False, True])
def test_save_read_round_trip(tmp_path, custom, ext, as_path):
    path = pathlib.Path(tmp_path) / f"liff.{ext}"
    custom.save(path if as_path else str(path))
    assert path.stat().st_size > 0
    d = liff.LiFF.create()
    d.read(path if as_path else str(path))
    assert params(d) == params(custom)


@pytest.mark.parametrize("ext", EXTENSIONS)
def test_write_path_equals_save(tmp_path, custom, ext):
    custom.write(str(tmp_path / f"a.{ext}"))
    custom.save(str(tmp_path / f"b.{ext}"))
    assert (tmp_path / f"a.{ext}").read_bytes() == (tmp_path / f"b.{ext}").read_bytes()


@pytest.mark.parametrize("ext", EXTENSIONS)
def test_defaults_round_trip_overwrites_everything(tmp_path, ext):
    path = str(tmp_path / f"defaults.{ext}")
    liff.LiFF.create().save(path)
    d = liff.LiFF.create(**CUSTOM)
    d.read(path)
    assert params(d) == params(liff.LiFF.create())


@pytest.mark.parametrize("first, last", [(-math.inf, math.inf), (-1.5, math.inf),
                                         (-math.inf, 2.0), (-0.75, 1.25)])
def test_json_files_are_json_with_open_slope_range_ends(tmp_path, first, last):
    """JSON has no infinity: an open end of the slope range (the automatic range's
    default) is written as the string "inf" / "-inf", so Python's json reads the file,
    and read() takes it back (from a file written by hand too)."""
    path = tmp_path / "p.json"
    liff.LiFF.create(firstSlope=first, lastSlope=last).save(str(path))
    values = json.loads(path.read_text())
    as_json = {-math.inf: "-inf", math.inf: "inf"}
    assert values["firstSlope"] == as_json.get(first, first)
    assert values["lastSlope"] == as_json.get(last, last)
    d = liff.LiFF.create(firstSlope=0.1, lastSlope=0.2)
    d.read(str(path))
    assert (d.getFirstSlope(), d.getLastSlope()) == (first, last)
    values["nfeatures"] = 5
    path.write_text(json.dumps(values))
    d.read(str(path))
    assert (d.getFirstSlope(), d.getLastSlope(), d.getNFeatures()) == (first, last, 5)


def test_an_infinity_string_is_only_a_slope_range_end(tmp_path, custom):
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"sigma": "inf"}))
    with pytest.raises(ValueError, match="sigma"):
        custom.read(str(path))
    path.write_text(json.dumps({"firstSlope": "infinite"}))
    with pytest.raises(ValueError, match="firstSlope"):
        custom.read(str(path))


@pytest.mark.parametrize("ext", ["yml", "xml", "json"])
def test_write_into_named_node_and_read_file_node(tmp_path, custom, ext):
    path = str(tmp_path / f"store.{ext}")
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    fs.write("before", 1)
    custom.write(fs, "liff_params")
    fs.write("after", "x")
    fs.release()

    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    assert fs.getNode("before").real() == 1 and fs.getNode("after").string() == "x"
    node = fs.getNode("liff_params")
    assert node.isMap() and node.getNode("name").string() == "Feature2D.LiFF"
    d = liff.LiFF.create()
    d.read(node)
    fs.release()
    assert params(d) == params(custom)


@pytest.mark.parametrize("ext", ["yml", "xml", "json"])
def test_write_at_root_and_read_root(tmp_path, custom, ext):
    path = str(tmp_path / f"root.{ext}")
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    custom.write(fs)
    fs.release()
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    d = liff.LiFF.create()
    d.read(fs.root())
    assert params(d) == params(custom)
    # and the file is a plain FileStorage any OpenCV reader understands
    assert fs.getNode("nOctaveLayers").real() == 4
    assert fs.getNode("firstSlope").real() == pytest.approx(-0.75)


def test_in_memory_file_storage(custom):
    fs = cv2.FileStorage(".yml", cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY)
    custom.write(fs, "p")
    text = fs.releaseAndGetString()
    fs = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
    d = liff.LiFF.create()
    d.read(fs.getNode("p"))
    assert params(d) == params(custom)


def test_round_trip_preserves_results(tmp_path, custom, blob_lf):
    path = str(tmp_path / "p.yml")
    custom.setNFeatures(0)
    custom.save(path)
    restored = liff.LiFF.create()
    restored.read(path)
    a, da = custom.detectAndCompute(blob_lf)
    b, db = restored.detectAndCompute(blob_lf)
    assert [k.pt for k in a] == [k.pt for k in b] and (da == db).all()


def test_partial_file_changes_only_what_it_names(tmp_path, custom):
    path = tmp_path / "partial.yml"
    path.write_text("%YAML:1.0\n---\nnfeatures: 3\nsigma: 2.5\n")
    custom.read(str(path))
    expected = dict(CUSTOM, nfeatures=3, sigma=2.5)
    assert params(custom) == params(liff.LiFF.create(**expected))


BAD_FILES = {
    "negative sigma": ("sigma: -1.\n", "sigma"),
    "zero layers": ("nOctaveLayers: 0\n", "nOctaveLayers"),
    "nan slope": ("firstSlope: .nan\n", "firstSlope"),
    "bad descriptor type": ("descriptorType: 6\n", "descriptorType"),
    "negative nfeatures": ("nfeatures: 5\nnumSlopes: -2\n", "numSlopes"),
    "other algorithm": ("name: Feature2D.SIFT\nnfeatures: 5\n", "SIFT"),
    "low edge threshold": ("edgeThreshold: 0.25\n", "edgeThreshold"),
}


@pytest.mark.parametrize("body, word", BAD_FILES.values(), ids=BAD_FILES.keys())
def test_bad_value_raises_and_leaves_detector_unchanged(tmp_path, custom, body, word):
    path = tmp_path / "bad.yml"
    path.write_text("%YAML:1.0\n---\n" + body)
    before = params(custom)
    with pytest.raises(ValueError, match=word):
        custom.read(str(path))
    assert params(custom) == before
    # the same through a FileNode
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    with pytest.raises(ValueError, match=word):
        custom.read(fs.root())
    assert params(custom) == before


def test_unreadable_sources(tmp_path, custom):
    before = params(custom)
    with pytest.raises(ValueError, match="no file"):
        custom.read(str(tmp_path / "missing.yml"))
    with pytest.raises(TypeError, match="FileNode"):
        custom.read(42)
    assert params(custom) == before


@pytest.mark.parametrize(
    "text", ["garbage{{{", "{{{ this is not a FileStorage", "%YAML:1.0\n---\nsigma: [1, 2\n", "<opencv_storage><sigma>"]
)
def test_malformed_file_raises_value_error(tmp_path, custom, text):
    # read() documents ValueError when the file cannot be read. Observed bug: for
    # "{{{ this is not a FileStorage" (and other parse errors) OpenCV's parser error
    # (-212, StsParseError) escapes as RuntimeError; only "garbage{{{" gives ValueError.
    path = tmp_path / "malformed.yml"
    path.write_text(text)
    before = params(custom)
    with pytest.raises(ValueError):
        custom.read(str(path))
    assert params(custom) == before


def test_unwritable_destinations(tmp_path, custom):
    with pytest.raises(ValueError, match="writable"):
        custom.save(str(tmp_path / "no" / "such" / "dir" / "p.yml"))
    with pytest.raises(TypeError, match="FileStorage"):
        custom.write(3.5)


# --- hostile parameter files: deep nesting, size -----------------------------------------

def nested(kind, n):
    """A FileStorage document whose entry `a` is nested n levels deep."""
    if kind == "yaml-indent":
        return "%YAML:1.0\n---\n" + "".join(" " * i + "a:\n" for i in range(n)) + " " * n + "1\n"
    return {
        "yaml": "%YAML:1.0\n---\na: " + "[" * n + "]" * n + "\n",
        "yaml-map": "%YAML:1.0\n---\na: " + "{b: " * n + "1" + "}" * n + "\n",
        "yaml-block": "%YAML:1.0\n---\na: " + "- " * n + "1\n",
        "yaml-keys": "%YAML:1.0\n---\n" + "a:" * n + " 1\n",
        "json": '{"a": ' + "[" * n + "]" * n + "}\n",
        "xml": '<?xml version="1.0"?>\n<opencv_storage>' + "<a>" * n + "</a>" * n + "</opencv_storage>\n",
    }[kind]


NESTED_KINDS = ["yaml", "yaml-map", "yaml-block", "yaml-keys", "yaml-indent", "json", "xml"]
SUFFIX = {"json": ".json", "xml": ".xml"}


@pytest.mark.parametrize("kind", NESTED_KINDS)
def test_nesting_beyond_the_limit_is_refused(tmp_path, custom, kind):
    path = tmp_path / ("deep" + SUFFIX.get(kind, ".yml"))
    path.write_text(nested(kind, 100))
    before = params(custom)
    with pytest.raises(ValueError, match=r"nest.*64"):
        custom.read(str(path))
    assert params(custom) == before


@pytest.mark.parametrize("kind", NESTED_KINDS)
def test_nesting_within_the_limit_is_read(tmp_path, custom, kind):
    path = tmp_path / ("shallow" + SUFFIX.get(kind, ".yml"))
    text = nested(kind, 20)
    if kind == "json":
        text = text.replace('{"a": ', '{"nfeatures": 5, "a": ')
    elif kind == "xml":
        text = text.replace("<opencv_storage>", "<opencv_storage><nfeatures>5</nfeatures>")
    else:
        text = text.replace("---\n", "---\nnfeatures: 5\n")
    path.write_text(text)
    custom.read(str(path))
    assert custom.getNFeatures() == 5


DEEP_READ = textwrap.dedent(
    """
    import sys, liff
    d = liff.LiFF.create()
    try:
        d.read(sys.argv[1])
    except ValueError as e:
        print("ValueError:", e)
    """
)


@pytest.mark.parametrize("kind", ["yaml", "yaml-block", "yaml-keys", "json", "xml"])
def test_very_deep_file_does_not_crash_the_interpreter(tmp_path, kind):
    # OpenCV's FileStorage parsers recurse once per level: 75,000 levels (150 KB)
    # overflowed the stack (SIGSEGV) before read() checked the nesting itself.
    path = tmp_path / ("deep" + SUFFIX.get(kind, ".yml"))
    path.write_text(nested(kind, 100_000))
    proc = subprocess.run([sys.executable, "-c", DEEP_READ, str(path)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, f"rc={proc.returncode}\nstdout={proc.stdout}\nstderr={proc.stderr}"
    assert "ValueError:" in proc.stdout and "nest" in proc.stdout


def test_strings_and_comments_do_not_count_as_nesting(tmp_path, custom):
    path = tmp_path / "commented.yml"
    path.write_text("%YAML:1.0\n---\n# ]]]] }}}} <a><a>\nnote: \"]]]]]]\"\n"
                    "a: [ 1, [ 2, 3 ] ] # [[[[\nnfeatures: 4\n")
    custom.read(str(path))
    assert custom.getNFeatures() == 4
    # a closing bracket in a comment or a string closes nothing
    path.write_text("%YAML:1.0\n---\na: " + "[ # ]\n" * 100 + "]" * 100 + "\n")
    with pytest.raises(ValueError, match="nest"):
        custom.read(str(path))
    path = tmp_path / "commented.json"
    path.write_text('{ "a": ' + '[ "]", /* ] */\n' * 100 + '1' + ']' * 100 + "}\n")
    with pytest.raises(ValueError, match="nest"):
        custom.read(str(path))


def test_file_larger_than_the_limit_is_refused_before_parsing(tmp_path, custom):
    path = tmp_path / "huge.yml"
    with open(path, "w") as f:
        f.write("%YAML:1.0\n---\nnfeatures: 3\n")
        f.write(("# " + "x" * 77 + "\n") * (2 << 20 >> 6))  # 2.5 MiB of comments
    before = params(custom)
    with pytest.raises(ValueError, match=r"MiB|bytes"):
        custom.read(str(path))
    assert params(custom) == before


def test_matrices_and_nested_algorithm_files_are_read(tmp_path, custom):
    # what FileStorage writes beside parameters (a matrix) is within the limits
    for ext in EXTENSIONS:
        path = str(tmp_path / f"with_matrix.{ext}")
        fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
        fs.write("K", np.eye(3))
        custom.write(fs)
        fs.release()
        d = liff.LiFF.create()
        d.read(path)
        assert params(d) == params(custom), ext


@pytest.mark.parametrize("filler", ["#\n" * 500_000, "# " + "nfeatures:" * 100_000 + "\n"],
                         ids=["short lines", "keys in a comment"])
def test_checks_stay_linear_on_a_file_at_the_size_limit(tmp_path, custom, filler):
    # (the integer check had scanned each key's value to the end of the line: 63 s)
    import time
    path = tmp_path / "long.yml"
    path.write_text("%YAML:1.0\n---\nnfeatures: 3\n" + filler)
    start = time.perf_counter()
    custom.read(str(path))
    assert custom.getNFeatures() == 3 and time.perf_counter() - start < 5


def test_only_a_regular_file_is_read(tmp_path, custom):
    import os
    fifo = tmp_path / "p.yml"
    os.mkfifo(fifo)  # opening it would block until a writer came
    with pytest.raises(ValueError, match="not a regular file"):
        custom.read(str(fifo))
    with pytest.raises(ValueError, match="not a regular file"):
        custom.read(str(tmp_path))


# --- values as the file writes them: no wrapping, no NaN booleans -------------------------

WRAPPING = {
    "int 2^32 + 1": ("nfeatures", "4294967297"),
    "int beyond long": ("nfeatures", "99999999999999999999999"),
    "int 2^31": ("nOctaveLayers", "2147483648"),
    "negative beyond int": ("numSlopes", "-2147483649"),
    "hex beyond int": ("descriptorType", "0x100000005"),
    "bool 2^32 + 1": ("rootSift", "4294967297"),
}


@pytest.mark.parametrize("ext", EXTENSIONS)
@pytest.mark.parametrize("key, value", WRAPPING.values(), ids=WRAPPING.keys())
def test_integers_beyond_an_int_are_refused_as_written(tmp_path, custom, ext, key, value):
    # OpenCV's parser wraps them (4294967297 -> 1) before read() sees the node
    path = tmp_path / f"wrap.{ext}"
    path.write_text({
        "yml": f"%YAML:1.0\n---\n{key}: {value}\n",
        "yaml": f"%YAML:1.0\n---\nFeature2D.LiFF:\n   {key}: {value}\n",
        "json": f'{{\n    "{key}": {value}\n}}\n',
        "xml": f'<?xml version="1.0"?>\n<opencv_storage>\n<{key}>{value}</{key}>\n</opencv_storage>\n',
    }[ext])
    before = params(custom)
    with pytest.raises(ValueError, match=rf"{key} = {value}\b"):
        custom.read(str(path))
    assert params(custom) == before


@pytest.mark.parametrize("value", [".nan", ".inf", "2", "-1", "0.5"])
def test_booleans_only_from_0_or_1(tmp_path, custom, value):
    path = tmp_path / "bool.yml"
    path.write_text(f"%YAML:1.0\n---\nrootSift: {value}\n")
    before = params(custom)
    with pytest.raises(ValueError, match=r"rootSift = .*expected 0 or 1"):
        custom.read(str(path))
    assert params(custom) == before
    path.write_text("%YAML:1.0\n---\nrootSift: 0\nnfeatures: 2147483647\n")
    custom.read(str(path))
    assert not custom.getRootSift() and custom.getNFeatures() == 2147483647


def test_integers_beyond_an_int_through_a_file_node(tmp_path, custom):
    # cv2 may read 4294967297 as a 64-bit integer: refused, not wrapped nor taken as true
    path = tmp_path / "wrap.yml"
    path.write_text("%YAML:1.0\n---\nnfeatures: 4294967297\n")
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    before = params(custom)
    with pytest.raises(ValueError, match=r"nfeatures = 4294967297\b"):
        custom.read(fs.root())
    assert params(custom) == before


def test_a_file_node_with_other_keys_reads_the_parameters(custom):
    # keys cv2's writer refuses ("a.b") had escaped as cv2.error from read(FileNode)
    fs = cv2.FileStorage("%YAML:1.0\n---\na.b: 1\nc d: x\nnfeatures: 3\n",
                         cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
    custom.read(fs.root())
    assert custom.getNFeatures() == 3


HANGING_LAYOUTS = {
    "dash after a document end": "%YAML:1.0\n---\nnfeatures: 3\n...\n-x\n",
    "root not at column 0": "%YAML:1.0\n -<\n]\n-\n",
    "text after ---": "%YAML:1.0\n--- nfeatures: 3\n-x\n",
    "tagged root": "%YAML:1.0\n---\n!!map a:},-\n---\n\n- [\n",
}


@pytest.mark.parametrize("text", HANGING_LAYOUTS.values(), ids=HANGING_LAYOUTS.keys())
def test_a_yaml_layout_that_hangs_opencv_is_refused(tmp_path, text):
    # OpenCV 4's YAML parser looped forever on these (its top level skips three
    # characters after a document and then waits for "---")
    path = tmp_path / "hang.yml"
    path.write_text(text)
    proc = subprocess.run([sys.executable, "-c", DEEP_READ, str(path)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "ValueError:" in proc.stdout and "column 0" in proc.stdout, proc.stdout


def test_yaml_streams_as_opencv_writes_them_are_read(tmp_path, custom):
    path = tmp_path / "two.yml"
    path.write_text("%YAML:1.0\n---\nnfeatures: 3\n...\n---\nother: 1\n")
    custom.read(str(path))
    assert custom.getNFeatures() == 3


def test_a_parse_error_is_short_and_names_the_line(tmp_path, custom):
    # OpenCV names a document in memory by its text: a 5 KB file had made a 5 KB message
    path = tmp_path / "bad.json"
    path.write_text('{"nfeatures": 3, "x": ' + "x" * 5000 + "}\n")
    with pytest.raises(ValueError) as info:
        custom.read(str(path))
    message = str(info.value)
    assert len(message) < 500 and str(path) in message and "(1)" in message, message
