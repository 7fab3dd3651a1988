#!/usr/bin/env python3
"""Writes the seed inputs of fuzz/corpus/ (seed-*) and the reproducers of bugs found
and fixed (bug-*, kept as regression seeds) and of readers.KNOWN_BUGS (fuzz/known_bugs/)
(run from anywhere; overwrites those files, keeps anything else, e.g. inputs a fuzzing
run found worth keeping)."""

import io
import os
import sys
import zlib

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests"))
import readers  # noqa: E402
from lfhelpers import matlab_order, write_mat_v5, write_mat_v73  # noqa: E402

CORPUS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")


def pfm(magic=b"Pf", size=b"2 2", scale=b"-1.0", data=None, sep=b"\n"):
    channels = 3 if magic == b"PF" else 1
    if data is None:
        w, h = (int(x) for x in size.split())
        dtype = "<f4" if scale.startswith(b"-") else ">f4"
        data = np.linspace(-1, 1, w * h * channels).astype(dtype).tobytes()
    return magic + sep + size + sep + scale + sep + data


def png(image):
    ok, buf = cv2.imencode(".png", image)
    assert ok
    return buf.tobytes()


def view(i, shape=(4, 4, 3), dtype=np.uint8):
    return png((np.arange(np.prod(shape)).reshape(shape) * (i + 1) % 251).astype(dtype))


CFG = b"[extrinsics]\nnum_cams_x = 2\nnum_cams_y = 2\n\n[meta]\ndisp_min = -1.5\ndisp_max = 1.5\n"
GT = pfm(size=b"4 4")

SEEDS = {
    "pfm": {
        "grey-le": pfm(),
        "colour-be": pfm(b"PF", b"2 1", b"1.0"),
        "tabs-and-spaces": pfm(size=b"3\t1", sep=b" "),
        "truncated-data": pfm(size=b"4 4", data=bytes(20)),
        "truncated-header": b"Pf\n2 ",
        "bad-magic": pfm(magic=b"P6"),
        "zero-scale": pfm(scale=b"0", data=bytes(16)),
        "nan-scale": pfm(scale=b"nan", data=bytes(16)),
        "negative-width": pfm(size=b"-2 2", data=bytes(16)),
        "extra-data": pfm() + b"trailing",
        "empty": b"",
    },
    "hci": {
        "2x2-with-cfg-and-gt": readers.pack_folder(
            {"parameters.cfg": CFG, "gt_disp_lowres.pfm": GT,
             **{f"input_Cam{i:03d}.png": view(i) for i in range(4)}}),
        "1x1-no-cfg-grey": readers.pack_folder({"input_Cam000.png": view(0, (4, 4))}),
        "2x2-16bit": readers.pack_folder(
            {f"input_Cam{i:03d}.png": view(i, (4, 4, 3), np.uint16) for i in range(4)}),
        "missing-view": readers.pack_folder(
            {"parameters.cfg": CFG, **{f"input_Cam{i:03d}.png": view(i) for i in (0, 1, 3)}}),
        "mixed-sizes": readers.pack_folder(
            {"input_Cam000.png": view(0), "input_Cam001.png": view(1, (4, 5, 3)),
             "input_Cam002.png": view(2), "input_Cam003.png": view(3)}),
        "corrupt-png": readers.pack_folder({"input_Cam000.png": view(0)[:30]}),
        "gt-wrong-size": readers.pack_folder(
            {"input_Cam000.png": view(0), "gt_disp_lowres.pfm": pfm(size=b"3 3")}),
        "cfg-no-section": readers.pack_folder(
            {"parameters.cfg": b"num_cams_x = 1\n", "input_Cam000.png": view(0)}),
        "empty": b"",
    },
}


def npy(array):
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=True)
    return buffer.getvalue()


def npz(**arrays):
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


LF = (np.arange(2 * 2 * 3 * 4) % 7 / 7).reshape(2, 2, 3, 4).astype(np.float32)
SEEDS.update({
    "views": {
        "2x2-padded": readers.pack_folder({f"scene_{t:02d}_{s:02d}.png": view(2 * t + s)
                                           for t in range(2) for s in range(2)}),
        "2x2-one-based": readers.pack_folder({f"{t}_{s}.png": view(t + s)
                                              for t in (1, 2) for s in (1, 2)}),
        "missing-view": readers.pack_folder({f"v_{t}_{s}.png": view(t) for t, s in ((0, 0), (0, 1), (1, 0))}),
        "mixed-sizes": readers.pack_folder({"v_0_0.png": view(0), "v_0_1.png": view(1, (4, 5, 3))}),
        "no-views": readers.pack_folder({"notes.txt": b"nothing here"}),
    },
    "eslf": {
        "rgba-8x8": png((np.arange(8 * 8 * 4).reshape(8, 8, 4) % 255).astype(np.uint8)),
        "grey-odd-size": png((np.arange(7 * 9).reshape(7, 9) % 255).astype(np.uint8)),
        "16bit-bgr": png((np.arange(6 * 6 * 3).reshape(6, 6, 3) * 999 % 65535).astype(np.uint16)),
        "corrupt": png(np.zeros((4, 4), np.uint8))[:25],
        "empty": b"",
    },
    "mosaic": {
        "rgb-8x8": png((np.arange(8 * 8 * 3).reshape(8, 8, 3) % 255).astype(np.uint8)),
        "not-divisible": png(np.zeros((7, 8), np.uint8)),
        "corrupt": png(np.zeros((4, 4), np.uint8))[:25],
    },
    "npy": {
        "float32-4d": npy(LF),
        "uint8-5d-bgra": npy((LF[..., None].repeat(4, -1) * 255).astype(np.uint8)),
        "2d": npy(np.zeros((3, 3), np.float32)),
        "object": npy(np.array([None, 1], dtype=object)),
        "garbage": b"\x93NUMPY\x01\x00garbage",
    },
    "npz": {
        "light-field-key": npz(light_field=LF, gt_disparity=np.zeros((3, 4), np.float32)),
        "only-array": npz(data=LF),
        "two-arrays-no-key": npz(a=LF, b=LF),
        "not-a-zip": b"PK\x03\x04broken",
    },
    "any": {
        "npz-light-field": npz(light_field=LF),
        "npz-bad-dtype": npz(light_field=LF.astype(np.complex64)),
        "empty-zip": npz(),
    },
})


def via_file(write, suffix, *args) -> bytes:
    """The bytes a writer that wants a path (h5py, scipy) makes."""
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "file" + suffix)
        write(path, *args)
        with open(path, "rb") as f:
            return f.read()


def write_h5(path, datasets, attributes=None):
    import h5py

    with h5py.File(path, "w") as f:
        for name, data in datasets.items():
            f[name] = data
        f.attrs.update(attributes or {})


def lenslet_png(n=5, size=(8, 9), alpha=True):
    from liff import synthetic

    lf = synthetic.textured_layers((n, n) + size, noise_variance=0).light_field
    capture = synthetic.lenslet_capture(lf, border=0)
    image = capture.transpose(2, 0, 3, 1, 4).reshape(size[0] * n, size[1] * n, 4)
    return png(image if alpha else image[..., :3])


LF_U16 = (np.arange(2 * 3 * 4 * 5 * 4).reshape(2, 3, 4, 5, 4) * 2477 % 65535).astype(np.uint16)
SEEDS.update({
    "views": {
        **SEEDS["views"],
        "scene-id-prefix": readers.pack_folder({f"0421_{t:02d}_{s:02d}.png": view(2 * t + s)
                                                for t in range(2) for s in range(2)}),
        "block-8-10": readers.pack_folder({f"cam_{t}_{s}.png": view(t + s)
                                           for t in (8, 9, 10) for s in (8, 9)}),
        "cross-3x3": readers.pack_folder({f"v_{t}_{s}.png": view(t + s)
                                          for t, s in ((0, 1), (1, 0), (1, 1), (1, 2), (2, 1))}),
        "not-symmetric": readers.pack_folder({f"v_{t}_{s}.png": view(t + s)
                                              for t, s in ((0, 1), (1, 0), (1, 1), (1, 2), (2, 1), (0, 0))}),
        "two-scenes": readers.pack_folder({f"{scene}_0_{s}.png": view(s)
                                           for scene in (421, 422) for s in range(2)}),
    },
    "eslf-detect": {
        "lenslet-5-alpha": lenslet_png(5),
        "lenslet-4-no-alpha": lenslet_png(4, alpha=False),
        "noise": png(np.random.default_rng(0).integers(0, 256, (40, 45), dtype=np.uint8)),
        "corrupt": png(np.zeros((4, 4), np.uint8))[:25],
    },
    "mat": {
        "v5-uint16-rgbw": via_file(write_mat_v5, ".mat", {"LF": matlab_order(LF_U16)}),
        "v73-uint16-rgbw": via_file(write_mat_v73, ".mat", {"LF": matlab_order(LF_U16)}),
        "v5-hci-struct": via_file(write_mat_v5, ".mat", {"LF": {"LF": LF[..., None].astype(np.float64),
                                                               "disp_lowres": np.zeros((3, 4))}}),
        "v73-hci-struct": via_file(write_mat_v73, ".mat", {"LF": {"LF": LF.astype(np.float64),
                                                                 "disp_lowres": np.zeros((3, 4))}}),
        "v5-two-candidates": via_file(write_mat_v5, ".mat", {"a": LF, "b": LF}),
        "garbage": b"MATLAB 5.0 MAT-file" + bytes(200),
    },
    "hdf5": {
        "hci-2013": via_file(write_h5, ".h5", {"LF": (LF[..., None].repeat(3, -1) * 255).astype(np.uint8),
                                               "GT_DEPTH": LF},
                             {"dH": np.array([0.1]), "focalLength": np.array([9.5]), "shift": np.array([1.0])}),
        "grouped": via_file(write_h5, ".h5", {"data/lf": LF_U16}),
        "two-candidates": via_file(write_h5, ".h5", {"a": LF, "b": LF}),
        "matlab-v73": via_file(write_mat_v73, ".mat", {"LF": matlab_order(LF_U16)}),
        "garbage": b"\x89HDF\r\n\x1a\n" + bytes(100),
    },
})


# Reproducers of bugs found by fuzzing: fuzz/corpus/<reader>/bug-<id> once fixed,
# fuzz/known_bugs/<reader>/<id> while listed in readers.KNOWN_BUGS.
def with_cfg(cfg):
    return readers.pack_folder({"parameters.cfg": cfg,
                                **{f"input_Cam{i:03d}.png": view(i) for i in range(4)}})


def mat_with_type(code: int, compress: bool) -> bytes:
    """A MAT v5 file whose light field's data element claims type ``code``: scipy 1.17's
    loadmat crashes the interpreter on codes without a dtype (0, 8, 10, 11, 14, 15, 19)."""
    import struct

    import scipy.io

    buffer = io.BytesIO()
    scipy.io.savemat(buffer, {"LF": np.arange(24, dtype=np.uint16).reshape(1, 2, 3, 4)},
                     do_compression=False)
    data = bytearray(buffer.getvalue())
    tag = data.rfind(struct.pack("<II", 4, 48))  # the uint16 data: miUINT16, 48 bytes
    data[tag:tag + 4] = struct.pack("<I", code)
    if not compress:
        return bytes(data)
    body = zlib.compress(bytes(data[128:]))
    return bytes(data[:128]) + struct.pack("<II", 15, len(body)) + body


KNOWN_BUG_INPUTS = {
    "mat": {  # found by fuzzing on 2026-11-30: scipy's loadmat crashed; liff checks first
        "loadmat-type-8": mat_with_type(8, compress=False),
        "loadmat-type-0-compressed": mat_with_type(0, compress=True),
        "loadmat-type-99": mat_with_type(99, compress=False),
    },
    "hci": {
        "cfg-not-utf8": with_cfg(CFG + b"comment = caf\xe9\n"),
        "cfg-percent": with_cfg(CFG + b"focus = 50%\n"),
        "cfg-grid-not-integer": with_cfg(CFG.replace(b"num_cams_x = 2", b"num_cams_x = 2.0")),
        "cfg-disp-not-number": with_cfg(CFG.replace(b"-1.5", b"low")),
        "cfg-grid-zero": with_cfg(CFG.replace(b"= 2", b"= 0")),
        "cfg-grid-huge": with_cfg(CFG.replace(b"= 2", b"= 100000")),
    },
}


PARAMETERS = {
    "yaml": b"%YAML:1.0\n---\nnfeatures: 5\nsigma: 1.5\nrootSift: 1\nfirstSlope: -1.\n",
    "yaml-algorithm": b"%YAML:1.0\n---\nFeature2D.LiFF:\n   name: Feature2D.LiFF\n   nfeatures: 7\n",
    "yaml-matrix": (b"%YAML:1.0\n---\nK: !!opencv-matrix\n   rows: 2\n   cols: 2\n   dt: d\n"
                    b"   data: [ 1., 0., 0., 1. ]\nnOctaveLayers: 4\n"),
    "json": b'{\n    "nfeatures": 3,\n    "numSlopes": 9,\n    "lastSlope": 2.5\n}\n',
    "xml": (b'<?xml version="1.0"?>\n<opencv_storage>\n<nfeatures>4</nfeatures>\n'
            b"<edgeThreshold>8.</edgeThreshold>\n</opencv_storage>\n"),
    "deep-yaml": b"%YAML:1.0\n---\na: " + b"[" * 100 + b"]" * 100 + b"\n",
    "deep-block": b"%YAML:1.0\n---\na: " + b"- " * 100 + b"1\n",
    "deep-json": b'{"a": ' + b"[" * 100 + b"]" * 100 + b"}\n",
    "deep-xml": b'<?xml version="1.0"?>\n<opencv_storage>' + b"<a>" * 100 + b"</a>" * 100 + b"</opencv_storage>\n",
    "wrapping-int": b"%YAML:1.0\n---\nnfeatures: 4294967297\n",
    "nan-bool": b"%YAML:1.0\n---\nrootSift: .nan\n",
    "tagged": b"%YAML:1.0\n---\na: !x: !x: 1\n",
}
SEEDS["parameters"] = PARAMETERS


def main():
    for name, inputs in KNOWN_BUG_INPUTS.items():
        for bug, data in inputs.items():
            known = bug in readers.KNOWN_BUGS
            folder = (os.path.join(os.path.dirname(CORPUS), "known_bugs", name) if known
                      else os.path.join(CORPUS, name))
            os.makedirs(folder, exist_ok=True)
            with open(os.path.join(folder, bug if known else f"bug-{bug}"), "wb") as f:
                f.write(data)
    for name, seeds in SEEDS.items():
        assert name in readers.BY_NAME, name
        folder = os.path.join(CORPUS, name)
        os.makedirs(folder, exist_ok=True)
        for seed, data in seeds.items():
            with open(os.path.join(folder, f"seed-{seed}"), "wb") as f:
                f.write(data)


if __name__ == "__main__":
    main()
