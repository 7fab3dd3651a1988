"""The memory estimate a call checks its limit with (cpp/src/memory.hpp) against the
memory the call takes: within 25% above the measured peak, and below it by no more than
MARGIN_BELOW. Each measured case runs in a fresh process (benchmarks/memory.py, whose
larger cases give the table in docs/RELIABILITY.md)."""

from __future__ import annotations

import os
import re
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import liff
from liff import synthetic

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import memory  # noqa: E402  (benchmarks/memory.py)

#: The most the estimate may exceed the measured peak (issue 26: "within 25%").
MOST_ABOVE = 1.25
#: The most it may fall short of it: the estimate assumes a keypoint per 100 first-octave
#: pixels, the densest content measured has one per 85 (docs/RELIABILITY.md, "Memory").
MARGIN_BELOW = 0.10

#: Small cases (each under a second and 300 MB): single images and light fields, grey,
#: colour and float, first octave -1 and 0, one and two threads; and the densest content.
CASES = memory.QUICK + ["1x1x432x576:u8c3:fo-1:t2:dense", "3x7x200x300:u16:fo-1:t2:texture",
                        "5x5x256x256:u8:fo0:t1:dense"]


#: The sanitized run (.ci/sanitize.sh) preloads AddressSanitizer, whose redzones,
#: quarantine and shadow memory are not the memory a call takes.
SANITIZED = "asan" in os.environ.get("LD_PRELOAD", "")


@pytest.mark.skipif(SANITIZED, reason="AddressSanitizer's own memory is not the call's")
@pytest.mark.parametrize("case", CASES)
def test_estimate_is_within_25_percent_of_the_measured_peak(case):
    r = memory.measure(case, timeout=300)
    ratio = r["estimate"] / r["peak"]
    assert 1 - MARGIN_BELOW <= ratio <= MOST_ABOVE, (
        f"{case}: estimate {r['estimate'] / 2**20:.1f} MB, peak {r['peak'] / 2**20:.1f} MB "
        f"(ratio {ratio:.2f}; {r['keypoints']} keypoints, {r['slices']} slices, batch {r['batch']})")


def test_the_measured_cases_cover_what_the_estimate_depends_on():
    """The cases above vary every input the estimate has a term for."""
    cases = [memory.Case.parse(c) for c in CASES]
    assert {c.first_octave for c in cases} == {-1, 0}
    assert {c.threads for c in cases} == {1, 2}
    assert {c.shape[0] * c.shape[1] == 1 for c in cases} == {True, False}
    assert len({c.shape for c in cases}) >= 4 and len({c.dtype for c in cases}) >= 3


def estimate_when_refused(detector, lf) -> float:
    """The total in MB the MemoryError of detectAndCompute states when the call cannot
    fit in 1 kB."""
    detector.setMemoryLimitMB(1e-3)
    with pytest.raises(MemoryError) as info:
        detector.detectAndCompute(lf, None)
    return float(re.search(r"needs about (\d+) MB", str(info.value)).group(1))


def first_octave_pyramid_mb(height: int, width: int, first_octave: int, images: int) -> float:
    """MB of `images` images per octave over all octaves of the view's pyramid, counted
    here from the view size (cv::SIFT's octave count), not by the core."""
    up = 2 ** -first_octave
    octaves = int(round(np.log2(min(height, width) * up) - 2)) - first_octave
    pixels = sum((height * up >> o) * (width * up >> o) for o in range(octaves))
    return images * pixels * 4 / 2**20


@pytest.mark.parametrize("first_octave", [-1, 0])
def test_a_12_mp_photo_fits_4_gb(detector, first_octave):
    """Issue 26: a 12 MP photo (peak 2.9 GB measured, benchmarks/memory.py) was refused
    under a 4 GB limit, its estimate counting a window of three scale spaces where a
    single view has one slice. Its estimate now holds the one pyramid, and is under 4 GB."""
    detector.setFirstOctave(first_octave)
    need = estimate_when_refused(detector, np.zeros((3000, 4000), np.uint8))
    # A detection-only pyramid keeps 3 Gaussians and 5 DoGs per octave (nOctaveLayers 3).
    pyramid = first_octave_pyramid_mb(3000, 4000, first_octave, 8)
    # Besides it: the build scratch (4 first-octave images, 3 for firstOctave 0), the
    # keypoints, a few views' worth; a window of three pyramids (the old estimate: 3.6x)
    # would be over twice.
    assert pyramid < need < 4096 and need < 2 * pyramid


def test_a_48_mp_photo_fits_a_23_gb_machine(detector):
    """Issue 26: a 48 MP photo needs about 11 GB (cv2.SIFT about 10 GB); refused by default
    on a 23 GB machine. Its estimate is now well under that."""
    need = estimate_when_refused(detector, np.zeros((6000, 8000), np.uint8))
    assert first_octave_pyramid_mb(6000, 8000, -1, 8) < need < 16 * 1024


def test_the_message_names_what_a_single_view_holds(detector):
    detector.setMemoryLimitMB(1)
    with pytest.raises(MemoryError) as info:
        detector.detect(np.zeros((600, 800), np.uint8))
    message = str(info.value)
    assert "1 scale space(s) of" in message and "1 focal slice(s) of" in message
    assert re.search(r"\d+ MB for about \d+ keypoints", message)
    assert "memory limit of 1 MB" in message


def test_a_light_field_holds_the_window_of_its_batch(detector, restore_threads):
    """With an automatic range the plan is not known before the survey: a window of
    batch + 2 scale spaces; a finite range's plan caps it at its slices."""
    lf = np.zeros((5, 5, 200, 200), np.uint8)
    liff.setNumThreads(1)
    detector.setMemoryLimitMB(1)
    with pytest.raises(MemoryError, match=r"3 scale space\(s\) of"):
        detector.detect(lf)
    narrow = liff.LiFF.create(firstSlope=-0.5, lastSlope=0.5, numSlopes=2)
    narrow.setMemoryLimitMB(1)
    with pytest.raises(MemoryError, match=r"2 scale space\(s\) of"):
        narrow.detect(lf)


def test_the_estimate_bounds_the_cores_own_buffers(restore_threads):
    """The core's accounting (its buffers of a page or more, in use and kept, counted from
    an empty working memory) stays under the estimate, for detection with and without
    descriptors and for compute(), in this process."""
    lf = synthetic.textured_layers((5, 5, 160, 200)).light_field
    liff.setNumThreads(2)
    detector = liff.LiFF.create()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        keypoints, _ = detector.detectAndCompute(lf, None)
        assert len(keypoints) > 100
        for name, call in [("detect", lambda: detector.detect(lf)),
                           ("detectAndCompute", lambda: detector.detectAndCompute(lf, None)),
                           ("compute", lambda: detector.compute(lf, keypoints))]:
            liff.releaseWorkingMemory()
            liff._core._hooks.working_memory_peak(reset=True)
            call()
            held = liff._core._hooks.working_memory_peak()
            estimate = liff._core._hooks.memory_estimate(detector)
            assert estimate["batch"] == 2
            assert held <= estimate["total"] <= MOST_ABOVE * held + 4 * 2**20, name


def test_the_estimate_is_recorded_per_call(detector):
    assert liff._core._hooks.memory_estimate(detector)["batch"] == 0  # before the first call
    detector.detect(np.zeros((64, 64), np.uint8))
    first = liff._core._hooks.memory_estimate(detector)["total"]
    detector.detect(np.zeros((128, 128), np.uint8))
    assert liff._core._hooks.memory_estimate(detector)["total"] > first > 0


def test_a_bad_case_is_refused_with_its_format():
    with pytest.raises(ValueError, match="expected TxSxVxU:DTYPE:foF:tN:CONTENT"):
        memory.measure("5x5x256:u8:fo-1:t1:texture")
