"""liff.preprocess: luminance, gamma, one-histogram equalisation; inputs are never modified."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from liff import preprocess

DTYPES = [np.uint8, np.uint16, np.float32, np.float64]
SCALE = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0, np.dtype(np.float32): 1.0,
         np.dtype(np.float64): 1.0}


def light_field(shape, dtype, seed=0, skew=1.0):
    """Read-only light field of ``dtype``; intensities u ** skew for u uniform in [0, 1]."""
    values = np.random.default_rng(seed).random(shape) ** skew
    lf = values if SCALE[np.dtype(dtype)] == 1.0 else np.round(values * SCALE[np.dtype(dtype)])
    lf = lf.astype(dtype)
    lf.setflags(write=False)  # any in-place change raises
    return lf


def with_alpha(lf, seed=1):
    alpha = light_field(lf.shape[:4] + (1,), lf.dtype, seed)
    result = np.concatenate([lf, alpha], axis=-1)
    result.setflags(write=False)
    return result


def assert_one_monotonic_mapping(inputs, outputs, strict):
    """``outputs`` is one function of ``inputs`` (equal in, equal out, in any view),
    non-decreasing, and with ``strict`` increasing between distinct inputs."""
    values, inverse = np.unique(inputs.ravel(), return_inverse=True)
    out = outputs.ravel()
    lowest = np.full(values.size, np.inf)
    highest = np.full(values.size, -np.inf)
    np.minimum.at(lowest, inverse, out)
    np.maximum.at(highest, inverse, out)
    np.testing.assert_array_equal(lowest, highest)  # same mapping everywhere
    steps = np.diff(lowest)
    assert (steps > 0).all() if strict else (steps >= 0).all()


@pytest.mark.parametrize("dtype", DTYPES)
def test_prepare_gives_float32_in_unit_range_and_keeps_input(dtype):
    lf = light_field((3, 3, 12, 14, 3), dtype)
    before = lf.copy()
    result = preprocess.prepare(lf)
    assert result.dtype == np.float32 and result.shape == (3, 3, 12, 14)
    assert result.min() == 0.0 and result.max() == 1.0  # the stretch saturates both ends
    np.testing.assert_array_equal(lf, before)


@pytest.mark.parametrize("dtype", DTYPES)
def test_luminance_is_bt601_like_opencv(dtype):
    lf = light_field((2, 3, 8, 10, 3), dtype)
    grey = preprocess.to_luminance(lf)
    views = (lf.astype(np.float64) / SCALE[np.dtype(dtype)]).astype(np.float32).reshape(-1, 10, 3)
    expected = cv2.cvtColor(views, cv2.COLOR_BGR2GRAY).reshape(2, 3, 8, 10)
    assert grey.dtype == np.float32
    np.testing.assert_allclose(grey, expected, atol=1e-6)
    # blue weighs least: pure blue is darker than pure red
    blue, red = np.zeros((1, 1, 1, 1, 3), dtype), np.zeros((1, 1, 1, 1, 3), dtype)
    blue[..., 0] = red[..., 2] = SCALE[np.dtype(dtype)]
    assert preprocess.to_luminance(blue) == pytest.approx(0.114, abs=1e-6)
    assert preprocess.to_luminance(red) == pytest.approx(0.299, abs=1e-6)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("step", [
    lambda lf: preprocess.apply_gamma(lf, 0.5),
    lambda lf: preprocess.equalize(lf, "stretch"),
    lambda lf: preprocess.equalize(lf, "cdf"),
], ids=["gamma", "stretch", "cdf"])
def test_each_step_is_one_monotonic_mapping_for_all_views(dtype, step):
    lf = light_field((3, 4, 10, 10), dtype, skew=3.0)
    out = step(lf)
    assert out.dtype == np.float32 and out.shape == lf.shape
    assert 0.0 <= out.min() and out.max() <= 1.0
    # the stretch saturates its 0.1 % tails (and input 0 stays 0); elsewhere every step
    # is strictly increasing
    inside = (out > 0) & (out < 1)
    assert inside.mean() > 0.8
    assert_one_monotonic_mapping(lf[inside], out[inside], strict=True)
    assert_one_monotonic_mapping(lf, out, strict=False)


@pytest.mark.parametrize("method", ["stretch", "cdf"])
def test_views_keep_their_relative_brightness(method):
    """One histogram for the whole light field: a darker view stays darker (a per-view
    equalisation would make the two views identical)."""
    bright = light_field((1, 1, 32, 32), np.float32)[0, 0]
    lf = np.stack([bright, bright * 0.5])[None]  # (1, 2, 32, 32)
    out = preprocess.equalize(lf, method)
    assert np.mean(out[0, 1] < out[0, 0]) > 0.95
    assert abs(out[0, 0].mean() - out[0, 1].mean()) > 0.2


def test_cdf_equalisation_flattens_the_histogram():
    # mostly dark (not so dark that 5 % of the samples share the first of 65536 bins,
    # where the CDF is interpolated linearly)
    lf = light_field((4, 4, 32, 32), np.float32, skew=2.0)
    out = preprocess.equalize(lf, "cdf")
    quantiles = np.quantile(out, np.linspace(0.05, 0.95, 19))
    np.testing.assert_allclose(quantiles, np.linspace(0.05, 0.95, 19), atol=0.01)
    assert np.quantile(lf, 0.5) < 0.3  # (it was far from flat: 0.25)


def test_stretch_saturates_the_cutoff_and_rescales_linearly():
    values = np.random.default_rng(6).uniform(0.2, 0.6, (2, 2, 50, 50))
    out = preprocess.equalize(values, "stretch", cutoff_percent=1.0)
    assert np.mean(out == 0) == pytest.approx(0.01, abs=0.003)
    assert np.mean(out == 1) == pytest.approx(0.01, abs=0.003)
    inside = (out > 0) & (out < 1)
    slope, _ = np.polyfit(values[inside], out[inside], 1)  # linear: (x - lo) / (hi - lo)
    assert slope == pytest.approx(1 / 0.392, rel=0.02)
    np.testing.assert_allclose(np.polyval(np.polyfit(values[inside], out[inside], 1),
                                          values[inside]), out[inside], atol=1e-5)


@pytest.mark.parametrize("dtype", DTYPES)
def test_alpha_passes_through_untouched(dtype):
    lf = with_alpha(light_field((2, 2, 8, 8, 3), dtype))
    alpha = lf[..., 3].astype(np.float64) / SCALE[np.dtype(dtype)]
    for result in (preprocess.prepare(lf), preprocess.prepare(lf, luminance=False),
                   preprocess.apply_gamma(lf, 0.3), preprocess.equalize(lf, "cdf")):
        assert result.dtype == np.float32 and result.shape[-1] in (2, 4)
        np.testing.assert_array_equal(result[..., -1], alpha.astype(np.float32))
    grey_weight = preprocess.to_luminance(lf)
    assert grey_weight.shape == (2, 2, 8, 8, 2)
    np.testing.assert_allclose(grey_weight[..., 0], preprocess.to_luminance(lf[..., :3]))


def test_zero_weight_samples_do_not_shape_the_histogram():
    """Lytro lenslet corners (alpha 0) are black; they must not pull the stretch down."""
    valid = np.random.default_rng(7).uniform(0.4, 0.6, (3, 3, 16, 16))
    lf = valid.copy()
    lf[0] = 0.0  # a row of dark, invalid views
    weight = np.ones_like(lf)
    weight[0] = 0.0
    weighted = preprocess.equalize(np.stack([lf, weight], -1), "stretch")
    assert weighted[1:, ..., 0].min() == 0.0 and weighted[1:, ..., 0].max() == 1.0
    unweighted = preprocess.equalize(lf, "stretch")
    assert unweighted[1:].min() > 0.3  # there, the zeros set the lower bound
    with pytest.raises(ValueError, match="zero everywhere; expected some samples with weight > 0"):
        preprocess.equalize(np.stack([lf, 0 * weight], -1))


def test_colour_channels_share_one_mapping():
    lf = light_field((2, 2, 8, 8, 3), np.uint8, skew=2.0)
    grey_pixels = lf.copy()
    grey_pixels[0, 0, 0, 0] = 40  # B = G = R
    out = preprocess.prepare(grey_pixels, luminance=False)
    assert out.shape == lf.shape
    assert out[0, 0, 0, 0, 0] == out[0, 0, 0, 0, 1] == out[0, 0, 0, 0, 2]
    assert_one_monotonic_mapping(grey_pixels, out, strict=False)


def test_prepare_options_select_the_steps():
    lf = light_field((2, 2, 6, 6, 3), np.float32)
    grey = preprocess.to_luminance(lf)
    np.testing.assert_allclose(preprocess.prepare(lf, gamma=0.5, equalize=False), np.sqrt(grey),
                               rtol=1e-6)
    np.testing.assert_array_equal(preprocess.prepare(lf, gamma=None, equalize=False), grey)
    np.testing.assert_array_equal(preprocess.prepare(lf, gamma=1, equalize="cdf"),
                                  preprocess.equalize(grey, "cdf"))
    np.testing.assert_array_equal(preprocess.prepare(lf, luminance=False, equalize=False),
                                  np.sqrt(lf))


@pytest.mark.parametrize("shape", [(6, 7), (6, 7, 3), (6, 7, 2), (2, 2, 6, 7, 1)])
def test_images_and_single_channels(shape):
    out = preprocess.prepare(light_field(shape, np.uint8))
    grey_shape = shape[:-1] if len(shape) in (3, 5) else shape
    expected = grey_shape + (2,) if shape[-1] == 2 else grey_shape
    assert out.shape == expected and out.dtype == np.float32


def test_float_input_is_clipped_to_unit_range():
    lf = np.array([-0.5, 0.25, 2.0], np.float64).reshape(1, 1, 1, 3)
    np.testing.assert_array_equal(preprocess.to_float(lf), np.float32([[[[0, 0.25, 1]]]]))


@pytest.mark.parametrize("call, expected", [
    (lambda: preprocess.apply_gamma(np.zeros((2, 2)), 0), r"gamma = 0; expected a finite number > 0"),
    (lambda: preprocess.to_float(np.full((2, 2), np.nan)), r"NaN or infinity; expected finite"),
    (lambda: preprocess.equalize(np.zeros((2, 2)), "clahe"), r"expected 'stretch' or 'cdf'"),
    (lambda: preprocess.equalize(np.zeros((2, 2)), cutoff_percent=50), r"expected a value in \[0, 50\)"),
    (lambda: preprocess.equalize(np.zeros((2, 2)), bins=1), r"bins = 1; expected an integer >= 2"),
    (lambda: preprocess.prepare(np.zeros((2, 2, 2, 2, 5))), r"5 channels .*expected 1 \(grey\)"),
    (lambda: preprocess.prepare(np.zeros((2, 2), bool)), r"dtype bool; expected uint8"),
    (lambda: preprocess.prepare(np.zeros(5)), r"shape \(5,\); expected a light field"),
])
def test_errors_state_the_expectation(call, expected):
    with pytest.raises(ValueError, match=expected):
        call()


def test_constant_light_field_is_returned_as_float():
    lf = np.full((2, 2, 4, 4), 128, np.uint8)
    np.testing.assert_array_equal(preprocess.equalize(lf), np.float32(128 / 255))


@pytest.mark.parametrize("call, expected", [
    (lambda: preprocess.equalize(np.zeros((2, 2)), bins="a"), r"bins = 'a'; expected an integer >= 2"),
    (lambda: preprocess.equalize(np.zeros((2, 2)), bins=2.5), r"bins = 2\.5; expected an integer"),
    (lambda: preprocess.equalize(np.zeros((2, 2)), bins=np.inf), r"bins = inf; expected an integer"),
    (lambda: preprocess.equalize(np.zeros((2, 2)), bins=np.nan), r"bins = nan; expected an integer"),
    (lambda: preprocess.equalize(np.zeros((2, 2)), cutoff_percent=None),
     r"cutoff_percent = None; expected a value in \[0, 50\)"),
    (lambda: preprocess.equalize(np.zeros((2, 2)), cutoff_percent="1"), r"cutoff_percent = '1'"),
    (lambda: preprocess.equalize(np.zeros((2, 2)), cutoff_percent=np.nan), r"cutoff_percent = nan"),
    (lambda: preprocess.equalize(np.zeros((2, 2)), method=["cdf"]), r"method = \['cdf'\]; expected"),
    (lambda: preprocess.apply_gamma(np.zeros((2, 2)), "0.5"), r"gamma = '0\.5'; expected a finite number"),
    (lambda: preprocess.apply_gamma(np.zeros((2, 2)), np.inf), r"gamma = inf; expected a finite number"),
    (lambda: preprocess.prepare(np.zeros((2, 2)), gamma="0.5"), r"gamma = '0\.5'; expected a finite"),
    (lambda: preprocess.prepare(np.zeros((2, 2)), gamma=-1), r"gamma = -1; expected a finite number > 0"),
    (lambda: preprocess.prepare(np.zeros((2, 2)), equalize="clahe"),
     r"equalize = 'clahe'; expected True, False, 'stretch' or 'cdf'"),
    (lambda: preprocess.prepare(np.zeros((2, 2)), equalize=2), r"equalize = 2; expected True"),
])
def test_bad_options_name_the_parameter(call, expected):
    with pytest.raises(ValueError, match=expected):
        call()


def test_prepare_checks_its_options_before_any_work():
    """The options are checked before the light field is converted: with both wrong,
    the option is what is reported."""
    not_a_light_field = np.zeros(5)
    with pytest.raises(ValueError, match="gamma = '0.5'"):
        preprocess.prepare(not_a_light_field, gamma="0.5")
    with pytest.raises(ValueError, match="equalize = 'flat'"):
        preprocess.prepare(not_a_light_field, equalize="flat")


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("shape", [(3, 4, 9, 10, 3), (3, 4, 9, 10, 4), (9, 10), (9, 10, 2)])
@pytest.mark.parametrize("gamma, method", [(0.5, "stretch"), (0.3, "cdf"), (None, "stretch"),
                                           (1, "cdf"), (2.0, None)])
def test_prepare_is_the_public_steps_bit_for_bit(dtype, shape, gamma, method):
    """prepare works in place on one float copy; the result is exactly that of chaining
    the public steps (which each convert again)."""
    lf = light_field(shape, dtype, skew=2.0)
    for luminance in (True, False):
        expected = preprocess.to_luminance(lf) if luminance else preprocess.to_float(lf)
        if gamma is not None and gamma != 1:
            expected = preprocess.apply_gamma(expected, gamma)
        if method is not None:
            expected = preprocess.equalize(expected, method)
        result = preprocess.prepare(lf, luminance=luminance, gamma=gamma,
                                    equalize=method or False)
        assert result.dtype == expected.dtype and result.shape == expected.shape
        assert result.tobytes() == expected.tobytes()


@pytest.mark.parametrize("dtype", DTYPES)
def test_non_native_byte_order_is_accepted(dtype):
    """np.save of a big-endian array, e.g. '>f4', gives the same result as native
    (and '>u2' is still scaled as uint16)."""
    lf = with_alpha(light_field((2, 3, 6, 7, 3), dtype))
    swapped = lf.astype(lf.dtype.newbyteorder("S"))
    assert not swapped.dtype.isnative or swapped.dtype.itemsize == 1
    for step in (preprocess.to_float, preprocess.to_luminance, preprocess.prepare,
                 lambda x: preprocess.equalize(x, "cdf"), lambda x: preprocess.apply_gamma(x, 0.3)):
        expected, result = step(lf), step(swapped)
        assert result.dtype == np.float32 and result.dtype.isnative
        assert result.tobytes() == expected.tobytes()
    with pytest.raises(ValueError, match=r"dtype >i4; expected uint8, uint16, float32 or float64"):
        preprocess.to_float(np.zeros((2, 2), ">i4"))


def test_preprocess_accepts_the_dtypes_of_liff_io():
    from liff.io import _shared

    assert preprocess.LIGHT_FIELD_DTYPES is _shared.LIGHT_FIELD_DTYPES
