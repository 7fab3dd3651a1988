"""Shared fixtures for the liff test suite (light fields kept small, so the suite stays quick)."""

from __future__ import annotations

import numpy as np
import pytest

import lfhelpers
import liff
from liff import synthetic


@pytest.fixture
def detector():
    """A default detector (fresh per test: setters must not leak between tests)."""
    return liff.LiFF.create()


@pytest.fixture(scope="session")
def blob_scene():
    """(blobs, lf): 5x5 views of 96x96, Gaussian blobs on three layers, mild noise, [0, 1]."""
    shape = (5, 5, 96, 96)
    blobs = synthetic.random_blob_layers([-0.6, -0.1, 0.4], shape, blobs_per_layer=6, seed=3)
    lf = synthetic.render_disks(blobs, shape, profile="gaussian", noise_variance=1e-4, seed=1)
    lf = np.clip(lf, 0.0, 1.0)
    lf.setflags(write=False)  # shared between tests: nobody may modify it
    return blobs, lf


@pytest.fixture(scope="session")
def blob_lf(blob_scene):
    return blob_scene[1]


@pytest.fixture(scope="session")
def texture_image():
    """A 160x160 uint8 image of smoothed noise (many SIFT features)."""
    img = lfhelpers.texture(160, 160, seed=0, sigma=3.0)
    img = np.round(img * 255).astype(np.uint8)
    img.setflags(write=False)
    return img


@pytest.fixture(scope="session")
def textured_plane():
    """5x5 views of 128x128: a textured plane at slope +1 (integer shifts, float32)."""
    lf = lfhelpers.textured_lf((5, 5, 128, 128), slope=1, seed=0)
    lf.setflags(write=False)
    return lf


@pytest.fixture
def restore_threads():
    """Restores liff's thread count after a test that changes it."""
    before = liff.getNumThreads()
    yield before
    liff.setNumThreads(before)
