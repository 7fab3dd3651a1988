"""A light field too large for the memory limit fails early with MemoryError naming
the estimate and the limit; a limit that fits only part of the work gives the same
results (fewer slices are built at once)."""

from __future__ import annotations

import re

import numpy as np
import pytest

import lfhelpers
import liff


def needed_mb(detector, lf) -> float:
    """The estimate the detector reports when it cannot fit in 1 kB."""
    detector.setMemoryLimitMB(1e-3)
    with pytest.raises(MemoryError) as info:
        detector.detect(lf)
    return float(re.search(r"needs about (\d+) MB", str(info.value)).group(1))


def test_default_limit_is_automatic(detector):
    assert detector.getMemoryLimitMB() == 0


def test_too_large_fails_early_with_a_clear_message(detector):
    lf = np.zeros((9, 9, 300, 400), np.uint8)  # 9.7 MB in, ~39 MB as float grey
    lf.setflags(write=False)
    detector.setMemoryLimitMB(10)
    with pytest.raises(MemoryError, match=r"9 x 9 views of 300 x 400 pixels needs about \d+ MB") as info:
        detector.detectAndCompute(lf, None)
    message = str(info.value)
    assert "memory limit of 10 MB" in message and "setMemoryLimitMB" in message
    # The estimate includes the grey float copy (9*9*300*400*4 bytes = 37 MB).
    assert re.search(r"grey light field 37 MB", message)


def test_estimate_grows_with_the_light_field(detector):
    small = needed_mb(detector, np.zeros((5, 5, 100, 100), np.uint8))
    large = needed_mb(detector, np.zeros((5, 5, 200, 200), np.uint8))
    assert 3.0 < large / small < 5.0  # ~4x the pixels


def test_a_tight_limit_gives_the_same_results(blob_lf, restore_threads):
    """With 4 threads the batch is 4 slices; a limit that fits one slice at a time must
    not change the result."""
    liff.setNumThreads(4)
    detector = liff.LiFF.create()
    reference_kps, reference_desc = detector.detectAndCompute(blob_lf, None)
    need = needed_mb(detector, np.repeat(blob_lf[..., None], 3, axis=-1))  # converts: counts grey
    detector.setMemoryLimitMB(need + 1)
    kps, desc = detector.detectAndCompute(blob_lf, None)
    lfhelpers.assert_same_keypoints(reference_kps, kps)
    np.testing.assert_array_equal(reference_desc, desc)


def test_no_limit(detector, blob_lf):
    detector.setMemoryLimitMB(float("inf"))
    assert len(detector.detect(blob_lf)) > 0


@pytest.mark.parametrize("bad", [-1.0, float("nan")])
def test_bad_limit_is_refused(detector, bad):
    with pytest.raises(ValueError, match="memoryLimitMB"):
        detector.setMemoryLimitMB(bad)
