"""Thread safety and determinism: results are bit-identical across runs, detectors,
processes, thread counts (liff.setNumThreads and cv2.setNumThreads) and concurrent
calls from Python threads on one shared detector."""

import hashlib
import subprocess
import sys
import textwrap
import threading
from concurrent.futures import ThreadPoolExecutor

import cv2
import numpy as np
import pytest

import liff
from lfhelpers import assert_same_keypoints, kp_fields


def digest(kps, desc):
    h = hashlib.sha256(np.array([kp_fields(k) for k in kps], dtype=np.float64).tobytes())
    h.update(b"" if desc is None else np.ascontiguousarray(desc).tobytes())
    return h.hexdigest()


@pytest.mark.parametrize("kwargs", [{}, dict(numSlopes=13), dict(nfeatures=10, rootSift=True)])
def test_two_runs_are_identical(blob_lf, kwargs):
    d = liff.LiFF.create(**kwargs)
    k1, d1 = d.detectAndCompute(blob_lf)
    k2, d2 = d.detectAndCompute(blob_lf)
    k3, d3 = liff.LiFF.create(**kwargs).detectAndCompute(blob_lf)  # a fresh detector
    assert len(k1) > 0
    assert_same_keypoints(k1, k2)
    assert_same_keypoints(k1, k3)
    np.testing.assert_array_equal(d1, d2)
    np.testing.assert_array_equal(d1, d3)


def test_other_work_in_between_does_not_change_results(blob_lf, texture_image):
    d = liff.LiFF.create()
    first = digest(*d.detectAndCompute(blob_lf))
    d.detectAndCompute(texture_image)
    d.detectAndCompute(np.random.default_rng(0).random((3, 7, 40, 50, 3)))
    assert digest(*d.detectAndCompute(blob_lf)) == first


@pytest.mark.parametrize("threads", [2, 3, 8])
@pytest.mark.parametrize("kwargs", [{}, dict(numSlopes=13)])
def test_thread_count_does_not_change_results(blob_lf, restore_threads, threads, kwargs):
    d = liff.LiFF.create(**kwargs)
    liff.setNumThreads(1)
    assert liff.getNumThreads() == 1
    k1, d1 = d.detectAndCompute(blob_lf)
    c1 = d.compute(blob_lf, k1)
    liff.setNumThreads(threads)
    assert liff.getNumThreads() == threads
    kn, dn = d.detectAndCompute(blob_lf)
    cn = d.compute(blob_lf, k1)
    assert_same_keypoints(k1, kn)
    np.testing.assert_array_equal(d1, dn)
    assert_same_keypoints(c1[0], cn[0])
    np.testing.assert_array_equal(c1[1], cn[1])


@pytest.mark.parametrize("threads", [2, 3])
def test_thread_count_does_not_change_the_automatic_range_of_textured_layers(restore_threads,
                                                                            threads):
    """The slope survey's plane sweep (docs/SLOPES.md) sums costs over slopes in chunks
    fixed in number, so its votes, the plan and the features do not depend on threads."""
    from liff import synthetic
    lf = synthetic.textured_layers((5, 5, 128, 128), (-2.0, 0.3, 2.1), seed=3).light_field
    d = liff.LiFF.create()
    liff.setNumThreads(1)
    plan1, (k1, d1) = d.slopesFor(lf), d.detectAndCompute(lf)
    liff.setNumThreads(threads)
    plan_n, (kn, dn) = d.slopesFor(lf), d.detectAndCompute(lf)
    assert plan1 == plan_n
    assert_same_keypoints(k1, kn)
    np.testing.assert_array_equal(d1, dn)


def test_thread_count_with_mask_and_2d(texture_image, restore_threads):
    d = liff.LiFF.create()
    mask = np.zeros(texture_image.shape, np.uint8)
    mask[20:140, 30:120] = 1
    liff.setNumThreads(1)
    serial = digest(*d.detectAndCompute(texture_image, mask))
    liff.setNumThreads(2)
    assert digest(*d.detectAndCompute(texture_image, mask)) == serial


def test_set_num_threads_negative_restores_default(restore_threads):
    liff.setNumThreads(1)
    liff.setNumThreads(-1)
    assert liff.getNumThreads() >= 1


def test_cv2_thread_count_does_not_change_results(blob_lf, restore_threads):
    # cv2.setNumThreads sets pip OpenCV's pool, not the core's (see NOTES); either way
    # the results must not move.
    before = cv2.getNumThreads()
    d = liff.LiFF.create()
    try:
        digests = set()
        for n in (1, 2, 8):
            cv2.setNumThreads(n)
            digests.add(digest(*d.detectAndCompute(blob_lf)))
    finally:
        cv2.setNumThreads(before)
    assert len(digests) == 1


@pytest.fixture(scope="module")
def varied_inputs(blob_lf, texture_image):
    """Eight different (light field, mask) inputs: 4-D, 5-D colour, 2-D, masked, uint8,
    non-contiguous, random, a sub-grid of views."""
    rng = np.random.default_rng(5)
    colour = np.ascontiguousarray(np.stack([blob_lf, blob_lf ** 2, 1 - blob_lf], axis=-1))
    mask = np.zeros(texture_image.shape, np.uint8)
    mask[10:100, 20:150] = 1
    return [
        (blob_lf, None),
        (colour, None),
        (texture_image, None),
        (texture_image, mask),
        ((blob_lf * 255).astype(np.uint8), None),
        (blob_lf[:, :, ::-1], None),
        (rng.random((3, 4, 40, 50)).astype(np.float32), None),
        (blob_lf[1:4, 1:4], None),
    ]


@pytest.mark.parametrize("same_input", [True, False], ids=["same-input", "different-inputs"])
@pytest.mark.parametrize("kwargs", [{}, dict(nfeatures=20, rootSift=True, descriptorType=cv2.CV_8U)])
def test_one_detector_from_eight_python_threads_equals_serial(varied_inputs, same_input, kwargs):
    # The GIL is released during detection, so eight threads really run the core at
    # once on one shared detector object.
    shared = liff.LiFF.create(**kwargs)
    jobs = [varied_inputs[0]] * 16 if same_input else varied_inputs * 2
    serial = [digest(*shared.detectAndCompute(lf, mask)) for lf, mask in jobs]
    assert len(set(serial)) == (1 if same_input else len(varied_inputs))
    barrier = threading.Barrier(8)

    def work(job):
        lf, mask = job
        barrier.wait(timeout=60)
        return digest(*shared.detectAndCompute(lf, mask))

    with ThreadPoolExecutor(max_workers=8) as pool:
        first = list(pool.map(work, jobs[:8]))  # all eight start together
        rest = list(pool.map(lambda j: digest(*shared.detectAndCompute(*j)), jobs[8:]))
    assert first + rest == serial


def test_concurrent_detect_compute_and_setters_on_separate_detectors(blob_lf):
    # Mixed calls at once: detect, compute and detectAndCompute on several detectors.
    d = liff.LiFF.create()
    kps, desc = d.detectAndCompute(blob_lf)
    expected = (digest(kps, None), digest(*d.compute(blob_lf, kps)), digest(kps, desc))
    calls = [lambda: digest(liff.LiFF.create().detect(blob_lf), None),
             lambda: digest(*liff.LiFF.create().compute(blob_lf, kps)),
             lambda: digest(*d.detectAndCompute(blob_lf))] * 3
    with ThreadPoolExecutor(max_workers=8) as pool:
        results = list(pool.map(lambda f: f(), calls))
    assert results == list(expected) * 3


SCRIPT = textwrap.dedent(
    """
    import hashlib, sys
    import numpy as np, liff
    from liff import synthetic
    shape = (5, 5, 64, 64)
    blobs = synthetic.random_blob_layers([-0.5, 0.4], shape, blobs_per_layer=5, seed=2)
    lf = synthetic.render_disks(blobs, shape, profile="gaussian", noise_variance=1e-4, seed=3)
    liff.setNumThreads(int(sys.argv[1]))
    kps, desc = liff.LiFF.create().detectAndCompute(lf)
    rows = [(k.pt[0], k.pt[1], k.size, k.angle, k.response, k.octave, k.class_id) for k in kps]
    h = hashlib.sha256(np.array(rows, dtype=np.float64).tobytes() + desc.tobytes())
    print(len(kps), h.hexdigest())
    """
)


def test_identical_across_processes_and_thread_counts():
    outs = [
        subprocess.run([sys.executable, "-c", SCRIPT, str(n)], capture_output=True, text=True,
                       timeout=120, check=True).stdout.split()[-2:]
        for n in (1, 2, 8)
    ]
    assert int(outs[0][0]) > 0
    assert outs[0] == outs[1] == outs[2]
