"""Results are bit-identical across runs, detectors, processes and thread counts."""

import hashlib
import subprocess
import sys
import textwrap
import threading

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


@pytest.mark.parametrize("threads", [2, 3, 5])
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


def test_concurrent_calls_from_python_threads(blob_lf):
    # The GIL is released during detection; concurrent calls on separate detectors
    # and on one shared detector must give the serial answer.
    expected = digest(*liff.LiFF.create().detectAndCompute(blob_lf))
    shared = liff.LiFF.create()
    results, errors = [], []

    def work(detector):
        try:
            for _ in range(3):
                results.append(digest(*detector.detectAndCompute(blob_lf)))
        except Exception as e:  # pragma: no cover - reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(d,))
               for d in (shared, shared, liff.LiFF.create(), liff.LiFF.create())]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not errors
    assert results == [expected] * 12


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


def test_identical_across_processes():
    outs = [
        subprocess.run([sys.executable, "-c", SCRIPT, str(n)], capture_output=True, text=True,
                       timeout=120, check=True).stdout.split()[-2:]
        for n in (1, 2)
    ]
    assert int(outs[0][0]) > 0
    assert outs[0] == outs[1]
