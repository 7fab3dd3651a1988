"""Every reader that learns a size before decoding refuses, before allocating or
inflating anything, a light field that does not fit the memory budget (issue 32):
a small file claiming, or inflating to, a large one is a MemoryError naming the file,
the size claimed and the budget.

The machine's memory available is replaced by a small figure (``available``) so that
files of a few hundred KB stand for files of GBs; the files claiming more than any
machine holds are read against the real figure.
"""

from __future__ import annotations

import re
import struct
import time
import zipfile

import numpy as np
import pytest

import liff
from lfhelpers import write_mat_v5, write_mat_v73, zero_png
from liff import _budget, io

MB = 10**6


@pytest.fixture
def available(monkeypatch):
    """Sets the memory available (what the budget leaves without a set budget), in MB."""
    def set_available(megabytes: float) -> None:
        monkeypatch.setattr(_budget, "available_bytes", lambda: int(megabytes * MB))
    return set_available


def refused(path, call, claimed_mb=None, budget_mb=None):
    """Runs ``call``; asserts a MemoryError naming ``path``, ``claimed_mb`` (the size the
    file claims, MB as the message writes it) and ``budget_mb``; returns the message."""
    with pytest.raises(MemoryError) as info:
        call()
    message = str(info.value)
    assert message.startswith(str(path)), message
    if claimed_mb is not None:
        assert f" takes {claimed_mb:,} MB; expected at most " in message, message
    if budget_mb is not None:
        assert f"the {budget_mb:,} MB of the memory available now" in message, message
    return message


def refused_then_read(path, source, claimed_mb, budget_mb, shape, available):
    """Refused (``refused``) with ``budget_mb`` available, read as ``shape`` with 100 MB
    more: the size checked is the one the file states, not a bound on every file."""
    available(budget_mb)
    refused(source, lambda: io.read_light_field(path), claimed_mb, budget_mb)
    available(budget_mb + 100)
    assert io.read_light_field(path).light_field.shape == shape


def npy_header(shape, dtype="<u1") -> bytes:
    """A version 1.0 .npy header claiming ``shape``, with no data after it."""
    header = repr({"descr": dtype, "fortran_order": False, "shape": tuple(shape)}).encode()
    header += b" " * (63 - (10 + len(header)) % 64) + b"\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header


# --- numpy -------------------------------------------------------------------------------

def test_an_npy_header_claiming_a_terabyte_is_refused(tmp_path):
    path = tmp_path / "claim.npy"
    path.write_bytes(npy_header((1000, 1000, 1000, 1000)))  # 128 bytes claiming 1 TB
    message = refused(path, lambda: io.read_light_field(path), claimed_mb=1_000_000)
    assert "(1000, 1000, 1000, 1000) uint8" in message


def test_an_npz_member_claiming_a_terabyte_is_refused(tmp_path):
    path = tmp_path / "claim.npz"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("light_field.npy", npy_header((1000, 1000, 1000, 1000)))
    refused(f"{path}['light_field']", lambda: io.read_light_field(path), claimed_mb=1_000_000)


def test_an_npz_that_inflates_past_the_budget_is_refused_before_inflating(tmp_path, available):
    path = tmp_path / "zeros.npz"
    np.savez_compressed(path, light_field=np.zeros((4, 4, 1000, 1000, 3), np.uint8))
    assert path.stat().st_size < 200_000  # 48 MB of zeros
    refused_then_read(path, f"{path}['light_field']", 48, 20, (4, 4, 1000, 1000, 3), available)


def test_an_npz_disparity_past_the_budget_is_refused(tmp_path, available):
    path = tmp_path / "lf.npz"
    np.savez_compressed(path, light_field=np.zeros((2, 2, 8, 8), np.uint8),
                        gt_disparity=np.zeros((5000, 5000), np.float64))
    available(20)
    refused(f"{path}['gt_disparity']", lambda: io.read_light_field(path), 200, 20)


# --- images: views folders, HCI scenes, ESLF and mosaics ------------------------------------

def test_a_views_folder_past_the_budget_is_refused_before_decoding_a_view(tmp_path, available):
    folder = tmp_path / "views"
    folder.mkdir()
    for t in range(3):
        for s in range(3):
            zero_png(folder / f"v_{t:02d}_{s:02d}.png", 3000, 2000)  # 6 MB each, 6 KB stored
    # every view fits in 40 MB, the 54 MB light field does not
    refused_then_read(folder, folder, 54, 40, (3, 3, 2000, 3000), available)


def test_a_view_larger_than_the_first_is_refused_from_its_header(tmp_path):
    folder = tmp_path / "views"
    folder.mkdir()
    for t, s in [(0, 0), (0, 1), (1, 0)]:
        zero_png(folder / f"v_{t:02d}_{s:02d}.png", 8, 8)
    zero_png(folder / "v_01_01.png", 30000, 30000)  # 900 MB decoded
    with pytest.raises(ValueError, match=r"v_01_01.png: view is 30000x30000 \(its header\); "
                                         r"expected 8x8, 1 channel\(s\), uint8 like v_00_00.png"):
        io.read_light_field(folder)


def test_an_hci_scene_past_the_budget_is_refused(tmp_path, available):
    folder = tmp_path / "scene"
    folder.mkdir()
    for index in range(9):
        zero_png(folder / f"input_Cam{index:03d}.png", 1000, 1000)  # 3 MB each as BGR
    available(20)
    message = refused(folder, lambda: io.read_light_field(folder), 27, 20)
    assert "3x3 views of 1000x1000 BGR" in message


@pytest.mark.parametrize("reader", ["eslf", "mosaic"])
def test_a_lenslet_image_or_mosaic_that_inflates_past_the_budget_is_refused(tmp_path, available,
                                                                             reader):
    path = tmp_path / "big.eslf.png"
    zero_png(path, 14 * 1000, 14 * 1000)  # 196 MB decoded, held twice (image, light field)
    assert path.stat().st_size < 400_000
    available(300)
    options = {"n": 14} if reader == "eslf" else {"grid": (14, 14)}
    message = refused(path, lambda: io.read_light_field(path, format=reader, **options), 392, 300)
    assert "an image of 14000x14000 with up to 1 channel(s) of 8 bits, 2 times" in message


def test_a_png_header_claiming_gigabytes_is_refused_without_decoding(tmp_path, available):
    path = tmp_path / "claim.png"
    zero_png(path, 4, 4)
    data = bytearray(path.read_bytes())  # 30000 x 30000 16-bit RGBA: 7.2 GB, < 2^30 pixels
    data[16:26] = struct.pack(">IIBB", 30000, 30000, 16, 6)
    data[29:33] = struct.pack(">I", __import__("zlib").crc32(bytes(data[12:29])) & 0xFFFFFFFF)
    path.write_bytes(bytes(data))
    available(1000)
    refused(path, lambda: io.images.read_image(path), 7_200, 1_000)


# --- MATLAB and HDF5 ------------------------------------------------------------------------

def test_a_mat_v5_variable_that_inflates_past_the_budget_is_refused(tmp_path, available):
    path = tmp_path / "zeros.mat"
    write_mat_v5(path, {"LF": np.zeros((3, 3, 500, 500, 3), np.float64)})  # 54 MB, compressed
    assert path.stat().st_size < 200_000
    available(20)
    started = time.perf_counter()
    refused(f"{path}['LF']", lambda: io.read_light_field(path), None, 20)
    assert time.perf_counter() - started < 1.0  # refused from the dimensions, not inflated
    available(200)
    assert io.read_light_field(path).light_field.shape == (3, 3, 500, 500, 3)


def test_a_mat_v5_struct_field_past_the_budget_is_refused(tmp_path, available):
    path = tmp_path / "struct.mat"
    write_mat_v5(path, {"LF": {"LF": np.zeros((3, 3, 500, 500, 3), np.uint8),
                               "disp_lowres": np.zeros((500, 500))}})
    available(5)
    message = refused(f"{path}['LF']", lambda: io.read_light_field(path), None, 5)
    assert "reading the variable (at least)" in message


def test_a_mat_v73_array_never_written_is_refused(tmp_path):
    import h5py

    path = tmp_path / "claim.mat"
    write_mat_v73(path, {"other": np.zeros((2, 2))})
    with h5py.File(path, "a") as f:  # 100 x 100 x 10000 x 10000 x 3: 3 TB, stored as nothing
        f.create_dataset("LF", shape=(3, 10000, 10000, 100, 100), dtype=np.uint8, chunks=True)
        f["LF"].attrs["MATLAB_class"] = np.bytes_("uint8")
    assert path.stat().st_size < 100_000
    refused(f"{path}['LF']", lambda: io.read_light_field(path), 3_000_000)


def test_an_hdf5_dataset_never_written_is_refused(tmp_path, available):
    import h5py

    path = tmp_path / "claim.h5"
    with h5py.File(path, "w") as f:  # the issue's 1.4 KB file that read as 6 GB
        f.create_dataset("LF", shape=(6, 10, 10000, 10000), dtype=np.uint8)
    assert path.stat().st_size < 10_000
    available(1000)
    message = refused(f"{path}['LF']", lambda: io.read_light_field(path), 6_000, 1_000)
    assert "a dataset of shape (6, 10, 10000, 10000) uint8" in message


def test_a_gzip_chunked_hdf5_dataset_past_the_budget_is_refused(tmp_path, available):
    import h5py

    path = tmp_path / "zeros.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("LF", data=np.zeros((3, 3, 1000, 1000, 3), np.uint8), compression="gzip")
    assert path.stat().st_size < 500_000
    refused_then_read(path, f"{path}['LF']", 27, 20, (3, 3, 1000, 1000, 3), available)


# --- PFM ------------------------------------------------------------------------------------

def test_a_pfm_header_claiming_gigabytes_is_refused(tmp_path, available):
    path = tmp_path / "claim.pfm"
    path.write_bytes(b"Pf\n100000 100000\n-1.0\n" + bytes(16))
    available(1000)  # 40 GB of float32 read, and as many again converted
    refused(path, lambda: io.read_pfm(path), 80_000, 1_000)


def test_a_pfm_header_padded_with_whitespace_is_refused_at_once(tmp_path):
    path = tmp_path / "padded.pfm"
    path.write_bytes(b"Pf" + b" " * 50_000_000 + b"2 2\n-1.0\n" + bytes(16))
    started = time.perf_counter()
    with pytest.raises(ValueError, match=re.escape(f"{path}: no PFM header in the first 4096 "
                                                   "bytes")):
        io.read_pfm(path)
    assert time.perf_counter() - started < 0.5  # was 13.5 s: a byte-at-a-time loop
    path.write_bytes(b"Pf" + b" " * 4000 + b"2 2\n-1.0\n" + bytes(16))  # padded, within bounds
    assert io.read_pfm(path).shape == (2, 2)


# --- the budget itself ----------------------------------------------------------------------

def test_a_set_budget_counts_what_the_process_holds(tmp_path, monkeypatch):
    """On a Dask worker (memory_budget_bytes set) the room is the budget less what the
    process holds, as the detector's limit is (liff.cli.common.make_detector)."""
    path = tmp_path / "lf.npy"
    np.save(path, np.zeros((2, 2, 1000, 1000, 3), np.uint8))  # 12 MB
    monkeypatch.setattr(_budget, "memory_budget_bytes", _budget.held_bytes() + 2 * MB)
    message = refused(path, lambda: io.read_light_field(path), 12)
    assert re.search(r"of the memory budget of [\d,]+ MB less the [\d,]+ MB the process holds",
                     message), message
    monkeypatch.setattr(_budget, "memory_budget_bytes", _budget.held_bytes() + 200 * MB)
    assert io.read_light_field(path).light_field.shape == (2, 2, 1000, 1000, 3)


def test_the_memory_available_is_the_cores_figure():
    """Without a set budget the room is what LiFF's core takes as its default limit."""
    available = _budget.available_bytes()
    assert available is not None and available > 0
    core_limit_mb = liff.LiFF.create().getMemoryLimitMB()
    assert core_limit_mb == 0  # 0: the memory available when a call starts, as here
    with open("/proc/meminfo") as f:
        mem_available = next(int(line.split()[1]) * 1024 for line in f
                             if line.startswith("MemAvailable:"))
    # (the core counts the working memory it keeps for reuse as available too)
    assert available <= mem_available * 1.05 + liff.keptWorkingMemoryBytes()
