"""The core keeps its working memory between calls (liff.keptWorkingMemoryBytes):
the same results from kept memory, what is kept bounded and released on request."""

import threading

import numpy as np
import pytest

import liff
from lfhelpers import assert_same_keypoints, blob_grid, textured_lf, to_dtype
from liff import synthetic


@pytest.fixture
def reuse_on():
    liff.setWorkingMemoryReuse(True)
    yield
    liff.setWorkingMemoryReuse(True)


def scene(shape, slopes):
    return synthetic.render_disks(blob_grid(shape, slopes), shape, profile="gaussian")


def detect(lf, **kwargs):
    return liff.LiFF.create(**kwargs).detectAndCompute(lf, None)


def test_a_second_call_from_kept_memory_gives_the_same_result(reuse_on):
    lf = scene((5, 5, 96, 128), [-0.5, 0.5])
    first, d1 = detect(lf)
    rows, d1 = [k.pt for k in first], d1.copy()  # the results outlive their arrays
    del first
    kept = liff.keptWorkingMemoryBytes()
    assert kept > 0  # the pyramids' buffers, at least
    second, d2 = detect(lf)
    assert [k.pt for k in second] == rows
    np.testing.assert_array_equal(d1, d2)
    # Kept memory is reused, not added to: the same call keeps the same amount once
    # its results (whose memory is the core's too) are freed.
    del second, d2
    assert liff.keptWorkingMemoryBytes() == kept


def test_results_are_the_callers_arrays(reuse_on):
    """The descriptors (and the keypoint rows) are numpy arrays over the core's memory,
    without a copy: writable, and unchanged by later calls."""
    lf = scene((3, 3, 64, 80), [0.0])
    _, d1 = detect(lf)
    saved = d1.copy()
    assert d1.flags.writeable and d1.flags.c_contiguous and d1.dtype == np.float32
    for _ in range(2):
        detect(lf)
    np.testing.assert_array_equal(d1, saved)
    d1[:] = 0  # the caller's to change


def test_kept_memory_serves_other_threads_and_other_sizes(reuse_on):
    small = scene((3, 3, 64, 80), [0.0])
    large = scene((5, 5, 120, 160), [-0.5, 0.5])
    expected = {name: detect(lf) for name, lf in (("small", small), ("large", large))}
    results = {}

    def run():
        for name, lf in (("large", large), ("small", small), ("large", large)):
            results[name] = detect(lf)

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    for name in expected:
        assert_same_keypoints(expected[name][0], results[name][0])
        np.testing.assert_array_equal(expected[name][1], results[name][1])


def test_release_and_turning_reuse_off_keep_nothing(reuse_on):
    lf = scene((3, 3, 64, 80), [0.0])
    detect(lf)
    assert liff.keptWorkingMemoryBytes() > 0
    liff.releaseWorkingMemory()
    assert liff.keptWorkingMemoryBytes() == 0
    liff.setWorkingMemoryReuse(False)
    assert liff.getWorkingMemoryReuse() is False
    kps, _ = detect(lf)
    assert liff.keptWorkingMemoryBytes() == 0
    liff.setWorkingMemoryReuse(True)
    again, _ = detect(lf)
    assert_same_keypoints(kps, again)
    assert liff.keptWorkingMemoryBytes() > 0


def test_kept_memory_gives_what_fresh_memory_gives_with_weights_too(reuse_on):
    """Grey and BGRA (alpha weights: a second buffer) light fields, detected with
    memory kept from earlier calls and with reuse off: the same features."""
    lf = to_dtype(textured_lf((5, 5, 60, 70), slope=1), np.uint8)
    alpha = np.random.default_rng(3).integers(100, 256, lf.shape, dtype=np.uint8)
    bgra = np.stack([lf, lf // 2, lf, alpha], axis=-1)
    for light_field in (lf, bgra):
        detect(light_field, firstSlope=-2, lastSlope=2, numSlopes=9)
        kept = detect(light_field, firstSlope=-2, lastSlope=2, numSlopes=9)
        liff.setWorkingMemoryReuse(False)
        fresh = detect(light_field, firstSlope=-2, lastSlope=2, numSlopes=9)
        liff.setWorkingMemoryReuse(True)
        assert len(kept[0]) > 10
        assert_same_keypoints(kept[0], fresh[0])
        np.testing.assert_array_equal(kept[1], fresh[1])


def _detect_in_child(lf, queue):
    queue.put(len(liff.LiFF.create().detect(lf)))


def test_a_process_forked_while_another_thread_detects_can_detect(reuse_on):
    """fork() while a thread allocates: the child's first detection must not deadlock on
    the working memory's lock (held across fork, pthread_atfork)."""
    import multiprocessing

    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork on this platform")
    lf = scene((3, 3, 64, 80), [0.0])
    expected = len(liff.LiFF.create().detect(lf))
    stop = threading.Event()

    def busy():
        while not stop.is_set():
            detect(lf)

    thread = threading.Thread(target=busy)
    thread.start()
    context = multiprocessing.get_context("fork")
    try:
        for _ in range(10):
            queue = context.Queue()
            child = context.Process(target=_detect_in_child, args=(lf, queue))
            child.start()
            child.join(60)
            assert child.exitcode == 0, "the forked child hung or failed"
            assert queue.get(timeout=5) == expected
    finally:
        stop.set()
        thread.join()
