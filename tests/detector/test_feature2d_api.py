"""The Feature2D surface: construction, parameters, return types, detect/compute consistency."""

import math

import cv2
import numpy as np
import pytest

import lfhelpers
import liff
from lfhelpers import assert_same_keypoints, kp_fields

DEFAULTS = dict(
    nfeatures=0, nOctaveLayers=3, contrastThreshold=0.04, edgeThreshold=10.0, sigma=1.6,
    firstSlope=-math.inf, lastSlope=math.inf, numSlopes=0, descriptorType=cv2.CV_32F, rootSift=False,
    firstOctave=-1,
)
CUSTOM = dict(
    nfeatures=17, nOctaveLayers=4, contrastThreshold=0.031, edgeThreshold=7.5, sigma=1.3,
    firstSlope=-0.75, lastSlope=1.25, numSlopes=9, descriptorType=cv2.CV_8U, rootSift=True,
    firstOctave=0,
)


# keyword -> accessor suffix (getNFeatures/setNFeatures, ...)
ACCESSOR = dict(
    nfeatures="NFeatures", nOctaveLayers="NOctaveLayers", contrastThreshold="ContrastThreshold",
    edgeThreshold="EdgeThreshold", sigma="Sigma", firstSlope="FirstSlope", lastSlope="LastSlope",
    numSlopes="NumSlopes", descriptorType="DescriptorType", rootSift="RootSift",
    firstOctave="FirstOctave",
)


def params_of(d):
    return {name: getattr(d, "get" + ACCESSOR[name])() for name in DEFAULTS}


def test_module_constants():
    assert liff.SLOPE_SCALE == 65536
    assert liff.getNumThreads() >= 1
    assert isinstance(liff.opencvVersion(), str) and liff.opencvVersion()[0].isdigit()


@pytest.mark.parametrize("factory", [liff.LiFF.create, liff.LiFF_create, liff.LiFF])
def test_defaults(factory):
    d = factory()
    assert params_of(d) == DEFAULTS
    assert isinstance(d, liff.LiFF)
    assert d.descriptorSize() == 128
    assert d.descriptorType() == cv2.CV_32F
    assert d.defaultNorm() == cv2.NORM_L2
    assert d.getDefaultName() == "Feature2D.LiFF"
    assert d.empty() is False


def test_create_keywords_and_positional():
    assert params_of(liff.LiFF.create(**CUSTOM)) == CUSTOM
    assert params_of(liff.LiFF_create(*CUSTOM.values())) == CUSTOM
    assert liff.LiFF.create(descriptorType=cv2.CV_8U).descriptorType() == cv2.CV_8U


@pytest.mark.parametrize("name", list(CUSTOM))
def test_setter_getter_round_trip(name):
    d = liff.LiFF.create()
    cap = ACCESSOR[name]
    getattr(d, "set" + cap)(CUSTOM[name])
    assert getattr(d, "get" + cap)() == CUSTOM[name]
    # and nothing else moved
    others = {k: v for k, v in params_of(d).items() if k != name}
    assert others == {k: v for k, v in DEFAULTS.items() if k != name}


def test_repr_names_parameters():
    text = repr(liff.LiFF.create(**CUSTOM))
    for name in CUSTOM:
        assert name in text


@pytest.mark.parametrize(
    "T, S, numSlopes, expected",
    [
        (7, 7, 0, 7), (9, 9, 0, 9), (4, 4, 0, 5), (6, 6, 0, 7), (2, 2, 0, 3),
        (1, 7, 0, 7), (5, 3, 0, 5), (3, 8, 0, 9), (5, 5, 11, 11), (5, 5, 1, 1),
    ],
)
def test_slopes_for(T, S, numSlopes, expected):
    d = liff.LiFF.create(firstSlope=-0.5, lastSlope=1.5, numSlopes=numSlopes)
    slopes = np.array(d.slopesFor(T, S))
    if expected == 1:
        # a single slope: only its count matters here (a 1x1 light field is tested below)
        assert len(slopes) == 1
    else:
        np.testing.assert_allclose(slopes, np.linspace(-0.5, 1.5, expected), atol=1e-12)


@pytest.mark.parametrize("first, last", [(-1, 1), (-0.5, 1.5), (0.25, 0.25)])
def test_slopes_for_single_view(first, last):
    d = liff.LiFF.create(firstSlope=first, lastSlope=last)
    assert d.slopesFor(1, 1) == pytest.approx([(first + last) / 2])


def test_keypoint_slopes_decoding():
    kps = [cv2.KeyPoint(1, 2, 3, -1, 0, 0, cid) for cid in (0, 65536, -32768, 12345)]
    np.testing.assert_array_equal(
        liff.keypoint_slopes(kps), [0.0, 1.0, -0.5, 12345 / 65536]
    )
    assert liff.keypoint_slopes([]).shape == (0,)
    assert liff.keypoint_slopes(()).dtype == np.float64


def test_return_types(detector, blob_lf):
    kps, desc = detector.detectAndCompute(blob_lf)
    assert isinstance(kps, tuple) and len(kps) > 10
    assert all(isinstance(k, cv2.KeyPoint) for k in kps)
    assert isinstance(desc, np.ndarray) and desc.dtype == np.float32 and desc.shape == (len(kps), 128)
    assert isinstance(detector.detect(blob_lf), tuple)
    # SIFT's descriptor: integers 0..255 stored as float32, L2 norm about 512
    np.testing.assert_array_equal(desc, np.round(desc))
    assert desc.min() >= 0 and desc.max() <= 255
    np.testing.assert_allclose(np.linalg.norm(desc, axis=1), 512, rtol=0.02)
    # the mask argument is accepted positionally, as cv2.SIFT.detectAndCompute(img, None)
    kps2, _ = detector.detectAndCompute(blob_lf, None)
    assert_same_keypoints(kps, kps2)


def test_descriptor_type_uint8_matches_float(blob_lf):
    k32, d32 = liff.LiFF.create().detectAndCompute(blob_lf)
    k8, d8 = liff.LiFF.create(descriptorType=cv2.CV_8U).detectAndCompute(blob_lf)
    assert d8.dtype == np.uint8
    assert_same_keypoints(k32, k8)
    np.testing.assert_array_equal(d8.astype(np.float32), d32)


def test_root_sift(blob_lf):
    kps, plain = liff.LiFF.create().detectAndCompute(blob_lf)
    kr, root = liff.LiFF.create(rootSift=True).detectAndCompute(blob_lf)
    assert_same_keypoints(kps, kr)
    assert root.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(root, axis=1), 512, rtol=0.02)
    # RootSIFT = sqrt of the L1-normalised descriptor (on SIFT's 512 scale). The
    # library roots the unrounded histogram, so compare loosely (observed: mean
    # |difference| 0.57 counts, max 7 on small entries).
    expected = 512 * np.sqrt(plain / plain.sum(axis=1, keepdims=True))
    assert np.abs(root - expected).mean() < 1.5
    assert np.abs(root - expected).max() < 16


def test_detect_then_compute_equals_detect_and_compute(detector, blob_lf):
    kps, desc = detector.detectAndCompute(blob_lf)
    detected = detector.detect(blob_lf)
    assert_same_keypoints(detected, kps)
    computed, desc2 = detector.compute(blob_lf, detected)
    assert_same_keypoints(computed, kps)
    assert np.abs(desc2 - desc).max() <= 1  # observed: identical


def test_compute_accepts_list_and_one_keypoint(detector, blob_lf):
    kps, desc = detector.detectAndCompute(blob_lf)
    full_k, full_d = detector.compute(blob_lf, list(kps))
    for i in (0, len(kps) // 2, len(kps) - 1):
        one_k, one_d = detector.compute(blob_lf, [kps[i]])
        assert len(one_k) == 1 and kp_fields(one_k[0]) == kp_fields(kps[i])
        np.testing.assert_array_equal(one_d[0], full_d[i])
        np.testing.assert_array_equal(one_d[0], desc[i])


def test_compute_keeps_the_given_order(detector, blob_lf):
    kps, desc = detector.detectAndCompute(blob_lf)
    perm = np.random.default_rng(0).permutation(len(kps))
    out_k, out_d = detector.compute(blob_lf, [kps[i] for i in perm])
    assert [kp_fields(k) for k in out_k] == [kp_fields(kps[i]) for i in perm]
    np.testing.assert_array_equal(out_d, desc[perm])


def test_compute_keeps_every_keypoint_in_place_as_cv2_sift(detector, blob_lf):
    """cv2.SIFT.compute keeps keypoints it cannot describe, with all-zero descriptors
    (checked here on the installed cv2), so arrays aligned with them stay aligned."""
    kps = detector.detect(blob_lf)
    good = kps[0]
    bad_octave = cv2.KeyPoint(good.pt[0], good.pt[1], good.size, good.angle, 0, 40 | (1 << 8), 0)
    nan_pt = cv2.KeyPoint(float("nan"), 10.0, good.size, good.angle, 0, good.octave, 0)
    zero_size = cv2.KeyPoint(10.0, 10.0, 0.0, 0.0, 0, good.octave, 0)
    negative_size = cv2.KeyPoint(10.0, 10.0, -1.0, 0.0, 0, good.octave, 0)
    nan_angle = cv2.KeyPoint(good.pt[0], good.pt[1], good.size, float("nan"), 0, good.octave, 0)
    given = [bad_octave, good, nan_pt, zero_size, negative_size, nan_angle]
    out_k, out_d = detector.compute(blob_lf, given)
    np.testing.assert_array_equal([kp_fields(k) for k in out_k], [kp_fields(k) for k in given])
    assert out_d.shape == (len(given), 128)
    _, alone = detector.compute(blob_lf, [good])
    np.testing.assert_array_equal(out_d[1], alone[0])
    assert np.linalg.norm(out_d[1]) > 0
    assert not out_d[[0, 2, 3, 4, 5]].any()
    # cv2.SIFT on the centre view does the same with the hand-made ones.
    view = (np.clip(blob_lf[blob_lf.shape[0] // 2, blob_lf.shape[1] // 2], 0, 1) * 255).astype(np.uint8)
    sift_k, sift_d = cv2.SIFT.create().compute(view, [cv2.KeyPoint(20, 20, 4), nan_pt, zero_size,
                                                      negative_size])
    assert len(sift_k) == 4 and not sift_d[1:].any()


def test_no_features_give_the_installed_cv2s_empty_descriptors(detector):
    """OpenCV 5's cv2.SIFT returns an empty (0, 128) array when it finds nothing, 4.x
    None: liff follows the installed cv2, in detectAndCompute and compute, and keeps the
    descriptor type."""
    blank = np.full((3, 3, 48, 48), 0.5)
    assert detector.detect(blank) == ()
    kps, desc = detector.detectAndCompute(blank, None)
    assert kps == ()
    lfhelpers.assert_no_descriptors(desc)
    assert detector.compute(blank, [])[0] == ()
    lfhelpers.assert_no_descriptors(detector.compute(blank, [])[1])
    as_bytes = liff.LiFF.create(descriptorType=cv2.CV_8U)
    lfhelpers.assert_no_descriptors(as_bytes.detectAndCompute(blank, None)[1], np.uint8)


def test_compute_rejects_non_keypoints(detector, blob_lf):
    with pytest.raises(TypeError, match="KeyPoint"):
        detector.compute(blob_lf, [(1.0, 2.0)])


def test_use_provided_keypoints_is_refused(detector, blob_lf):
    with pytest.raises(ValueError, match="compute"):
        detector.detectAndCompute(blob_lf, None, None, True)


@pytest.mark.parametrize("angle", [-1.0, -400.0, 359.9999, 360.0, 1e6, -1e6])
def test_compute_accepts_any_angle(angle):
    """cv2.KeyPoint's default angle is -1; angles outside [0, 360) describe as their
    value modulo 360 (this overflowed the descriptor histogram once)."""
    img = np.tile(np.linspace(0, 1, 64, dtype=np.float32), (64, 1))
    img = img + 0.2 * np.sin(np.arange(64, dtype=np.float32) / 3.0)[:, None]
    detector = liff.LiFF.create()
    kps, desc = detector.compute(img, [cv2.KeyPoint(32, 30, 6, angle)])
    assert len(kps) == 1 and desc.shape == (1, 128)
    assert 0 < np.linalg.norm(desc) < 600
    reduced = float(np.fmod(angle, 360.0)) % 360.0
    _, expected = detector.compute(img, [cv2.KeyPoint(32, 30, 6, reduced)])
    assert np.abs(desc.astype(int) - expected.astype(int)).max() <= 1


def test_compute_far_and_huge_keypoints_do_not_crash():
    img = np.random.default_rng(0).random((48, 48)).astype(np.float32)
    kps = [cv2.KeyPoint(1e5, -1e5, 10), cv2.KeyPoint(24, 24, 2e6), cv2.KeyPoint(1e30, 1, 3),
           cv2.KeyPoint(24, 24, 4)]
    out, desc = liff.LiFF.create().compute(img, kps)
    # Out-of-image keypoints are described (as cv2.SIFT does, with what little of their
    # window falls inside); coordinates or sizes of 1e6 and more keep their place with
    # an all-zero descriptor.
    assert [k.pt for k in out] == [k.pt for k in kps]
    assert desc.shape == (4, 128)
    assert not desc[1:3].any() and desc[3].any()


def test_default_slope_count_is_bounded():
    with pytest.raises(ValueError, match="axis order"):
        liff.LiFF.create(firstSlope=-1, lastSlope=1).slopesFor(1, 100000)


@pytest.mark.parametrize("first, last", [(-1.0, 1.0), (-12.0, 12.0)])
def test_focal_slices_do_not_depend_on_how_they_are_grouped(first, last):
    """Detection renders up to 6 focal slices per pass over the light field, compute()
    only the slices its keypoints need, a few at a time; each slice must be the same
    either way, so the descriptors are exactly equal. Wide slope ranges put the slices'
    source rows far apart."""
    from liff import synthetic

    lf = synthetic.textured_layers((7, 7, 72, 88), noise_variance=0).light_field
    d = liff.LiFF.create(firstSlope=first, lastSlope=last, numSlopes=13)
    kps, desc = d.detectAndCompute(lf)
    assert len(kps) > 20
    _, desc2 = d.compute(lf, kps[::-1])  # another order: other slice groups
    np.testing.assert_array_equal(desc2[::-1], desc)


def test_submodules_reachable_from_import_liff():
    """``import liff`` then ``liff.io.read_light_field`` (as the README writes it) works;
    unknown names still raise AttributeError."""
    code = ("import liff; assert callable(liff.io.read_light_field); "
            "assert callable(liff.preprocess.prepare); import sys; "
            "assert 'liff.colmap' not in sys.modules\n"
            "try:\n    liff.nothing\nexcept AttributeError as e:\n    assert 'nothing' in str(e)\n"
            "else:\n    raise SystemExit('no AttributeError')")
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


def test_parameter_table_is_the_one_definition():
    """liff.PARAMETERS (from C++'s LIFF_PARAMETERS) drives create(), the accessors and
    repr: its defaults are a new detector's, and each has a getter and a setter."""
    import inspect

    names = [p.name for p in liff.PARAMETERS]
    assert names == list(DEFAULTS)  # create()'s positional order, cv2.SIFT's first
    d = liff.LiFF.create()
    for p in liff.PARAMETERS:
        assert getattr(d, "get" + p.accessor)() == p.default == DEFAULTS[p.name]
        assert type(p.default) is p.type and p.help
        assert callable(getattr(d, "set" + p.accessor))
    signature = inspect.signature(liff.LiFF.create)
    assert [(q.name, q.default) for q in signature.parameters.values()] == [
        (p.name, p.default) for p in liff.PARAMETERS]
    assert inspect.signature(liff.LiFF).parameters.keys() == signature.parameters.keys()
    for p in liff.PARAMETERS:  # the class docstring documents each
        assert f"{p.name} : {p.type.__name__}" in liff.LiFF.__doc__


def test_create_rejects_unknown_and_repeated_arguments():
    with pytest.raises(TypeError, match="contrastThreshold"):
        liff.LiFF.create(contrastTreshold=0.02)
    with pytest.raises(TypeError, match="multiple values"):
        liff.LiFF.create(0, nfeatures=3)
    with pytest.raises(TypeError, match="at most 11"):
        liff.LiFF.create(*CUSTOM.values(), 1)
    with pytest.raises(TypeError, match="unexpected keyword"):
        liff._core.LiFF(foo=1)


def test_stubs_match_the_compiled_module():
    """python/liff/_core.pyi names exactly what liff._core has (so type checkers and
    IDEs see the real module), including every parameter's getter and setter."""
    import ast
    from pathlib import Path

    stub = ast.parse((Path(liff.__file__).parent / "_core.pyi").read_text())
    module_names, class_names, report_names = set(), set(), set()
    for node in stub.body:
        if isinstance(node, ast.FunctionDef):
            module_names.add(node.name)
        elif isinstance(node, ast.AnnAssign):
            module_names.add(node.target.id)
        elif isinstance(node, ast.ClassDef):
            module_names.add(node.name)
            if node.name == "LiFF":
                class_names = {n.name for n in node.body if isinstance(n, ast.FunctionDef)}
            elif node.name == "SlopeRangeReport":
                report_names = {n.target.id for n in node.body if isinstance(n, ast.AnnAssign)}
    core = liff._core
    assert module_names == {n for n in dir(core) if not n.startswith("__")}
    assert report_names == {n for n in vars(core.SlopeRangeReport) if not n.startswith("__")
                            and "pybind11" not in n}
    # (pybind11's own _pybind11_conduit_v1_ is not ours to stub)
    assert class_names - {"__init__"} == {n for n in vars(core.LiFF)
                                          if not n.startswith("__") and "pybind11" not in n}
    for p in liff.PARAMETERS:
        assert {"get" + p.accessor, "set" + p.accessor} <= class_names


def test_docstring_examples_run():
    """The LiFF docstring's Examples section is a doctest: it stays true."""
    import doctest

    from liff import _detector

    result = doctest.testmod(_detector, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted >= 5 and result.failed == 0


def test_readme_states_create_with_the_tables_defaults():
    """README, "Parameters": its create() signature is liff.PARAMETERS's, in order."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    match = re.search(r"`liff\.LiFF\.create\((.*?)\)`", text, re.S)
    assert match, "README has no `liff.LiFF.create(...)` signature"
    written = [part.split("=")[0].strip() for part in " ".join(match.group(1).split()).split(",")]
    assert written == [p.name for p in liff.PARAMETERS]


@pytest.mark.parametrize("given, error, words", [
    ("scene.npy", ValueError, "liff.io.read_light_field"),
    ([np.zeros((32, 32), np.float32), "x"], ValueError, "expected an array"),
    ([[0.0, 1.0], [2.0]], ValueError, "expected an array"),
])
def test_a_path_or_a_ragged_list_is_refused_naming_what_was_expected(given, error, words):
    with pytest.raises(error, match=words):
        liff.LiFF.create().detect(given)


@pytest.mark.parametrize("parameter", [p for p in liff.PARAMETERS if p.type is not bool],
                         ids=lambda p: p.name)
def test_every_numeric_parameter_has_a_range(parameter):
    """Step 2 of adding a parameter (liff/parameters.hpp): its range in
    Parameters::check(). A number no parameter takes (NaN, the most negative int) is
    refused by create() and by the setter, naming the parameter."""
    bad = math.nan if parameter.type is float else -2**31
    with pytest.raises(ValueError, match=parameter.name):
        liff.LiFF.create(**{parameter.name: bad})
    with pytest.raises(ValueError, match=parameter.name):
        getattr(liff.LiFF.create(), "set" + parameter.accessor)(bad)


def test_every_field_of_the_slope_range_report_is_bound():
    """A field added to liff::SlopeRangeReport (liff/liff.hpp) reaches Python: the
    struct's members are the bound class's attributes (and the stubs test holds those)."""
    import re
    from pathlib import Path

    header = (Path(__file__).resolve().parents[2] / "cpp" / "include" / "liff" /
              "liff.hpp").read_text()
    body = re.search(r"struct SlopeRangeReport \{(.*?)\n\};", header, re.S).group(1)
    code = "\n".join(line.split("//")[0] for line in body.splitlines())
    members = set()
    for declaration in re.findall(r"([^;{}]+);", code):
        declaration = re.sub(r"=[^,]*", "", declaration)  # default values
        names = re.findall(r"(\w+)\s*(?:,|$)", declaration.strip())
        members |= set(names)
    bound = {n for n in vars(liff._core.SlopeRangeReport)
             if not n.startswith("__") and "pybind11" not in n}
    assert members == bound
