"""``liff synth KIND --out PATH``: synthetic light fields with their ground truth."""

from __future__ import annotations

import argparse
import json
import os
from dataclasses import asdict
from typing import Callable, Dict

import numpy as np

from .. import captures, io, synthetic
from ..outputs import atomic_output
from . import common

KINDS = ("disks", "layers", "poses")
FORMATS = ("npz", "views", "eslf", "mosaic")
#: (views, (V, U)) when --views / --size are not given
DEFAULT_SHAPES = {"disks": (9, (256, 256)), "layers": (9, (256, 256)), "poses": (7, (240, 320))}


def add_parser(sub) -> None:
    p = sub.add_parser(
        "synth", help="write a synthetic light field (or a capture of several) with known answers",
        description="disks: the paper's noise scene (26 disks, contrast 0.1, slopes in "
                    "[-1, 1]); layers: three textured fronto-parallel layers with partial "
                    "occlusion; poses: a box scene seen from several camera poses, one light "
                    "field per pose in the folder --out (pose00, pose01, ...), for liff sfm. "
                    "npz keeps float32 and the ground truth in one file; image formats are "
                    "written as 16-bit PNG with the truth in <out>.truth.json (disks, poses: "
                    "intrinsics and each pose) or <out>.slopes.npy (layers).")
    p.add_argument("kind", choices=KINDS, help="the scene: " + ", ".join(KINDS))
    p.add_argument("--out", required=True,
                   help="output file (npz, eslf, mosaic) or folder (views; poses: the folder "
                        "of the light fields)")
    p.add_argument("--format", choices=FORMATS, default="npz",
                   help="how each light field is stored (default npz)")
    p.add_argument("--views", type=common.positive_int, default=None,
                   help="T = S (default 9; poses: 7)")
    p.add_argument("--size", type=common.positive_int, nargs=2, default=None, metavar=("V", "U"),
                   help="view size (default 256 256; poses: 240 320)")
    p.add_argument("--poses", type=common.positive_int, default=5, metavar="N",
                   help="poses: how many camera poses (default 5)")
    p.add_argument("--noise", type=common.nonnegative_float, default=0.0, help="noise variance (default 0)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the scene and the noise (default 0); the same seed gives the "
                        "same files")
    p.add_argument("--overwrite", action="store_true", help="replace an existing output")
    p.set_defaults(run=run)


def shape_of(args: argparse.Namespace) -> tuple:
    views, size = DEFAULT_SHAPES[args.kind]
    views = views if args.views is None else args.views
    size = size if args.size is None else args.size
    return (views, views, size[0], size[1])


def render(args: argparse.Namespace):
    """(light field float32 (T, S, V, U), truth dict of arrays / lists) of disks or layers."""
    shape = shape_of(args)
    if args.kind == "disks":
        blobs = synthetic.paper_disks(shape=shape, seed=args.seed)
        lf = synthetic.render_disks(blobs, shape, noise_variance=args.noise, seed=args.seed)
        return lf.astype(np.float32), {"blobs": [asdict(b) for b in blobs]}
    scene = synthetic.textured_layers(shape, seed=args.seed, noise_variance=args.noise)
    return scene.light_field, {"slope_map": scene.slope_map}


def light_field_path(out: str, fmt: str) -> str:
    """``out`` with the ending its format needs (numpy would append .npz anyway)."""
    return out + ".npz" if fmt == "npz" and not out.endswith(".npz") else out


def write_light_field(path: str, lf: np.ndarray, fmt: str, arrays: dict) -> None:
    """Writes ``lf`` at ``path`` atomically: npz (float32, with ``arrays`` beside it) or
    16-bit PNG views, ESLF or mosaic."""
    with atomic_output(path, folder=fmt == "views") as partial:
        if fmt == "npz":
            np.savez_compressed(partial, light_field=lf, **arrays)
            return
        image = np.round(np.clip(lf, 0, 1) * 65535).astype(np.uint16)
        writers: Dict[str, Callable[..., object]] = {
            "views": io.write_views, "eslf": io.write_eslf, "mosaic": io.write_mosaic}
        writer = writers[fmt]
        writer(partial, image)


def write_truth(base: str, truth: dict) -> str:
    """The ground truth beside an image-format output: JSON, or .npy for a slope map."""
    if "slope_map" in truth:
        path = base + ".slopes.npy"
        with atomic_output(path) as partial:
            np.save(partial, truth["slope_map"])
    else:
        path = base + ".truth.json"
        with atomic_output(path) as partial, open(partial, "w") as f:
            json.dump(truth, f, indent=1)
    return path


def write_poses(args: argparse.Namespace) -> None:
    """``args.poses`` light fields of one box scene, ``out/poseNN``, and their truth."""
    T, S, V, U = shape_of(args)
    scene = captures.box_scene(args.seed)
    poses = captures.arc_poses(args.poses, seed=args.seed)
    ending = {"npz": ".npz", "views": "", "eslf": ".eslf.png", "mosaic": ".png"}[args.format]
    with atomic_output(args.out, folder=True) as folder:
        for i in common.progress(range(len(poses)), "liff synth", unit="pose"):
            capture = captures.make_capture(args.seed, views=(T, S), size=(V, U),
                                            patches=scene, poses=[poses[i]])
            lf = capture.light_fields[0]
            if args.noise:
                lf = captures.degrade(capture, noise_variance=args.noise, seed=args.seed + i).light_fields[0]
            write_light_field(os.path.join(folder, f"pose{i:02d}{ending}"), lf, args.format, {})
    k = capture.intrinsics
    write_truth(args.out.rstrip(os.sep), {
        "intrinsics": {"focal": k.focal, "cx": k.cx, "cy": k.cy, "width": k.width, "height": k.height},
        "baseline": capture.baseline, "focus_depth": capture.focus_depth,
        "poses": [{"name": f"pose{i:02d}", "rotation": p.rotation.tolist(),
                   "translation": p.translation.tolist()} for i, p in enumerate(poses)]})


def run(args: argparse.Namespace) -> int:
    if args.kind != "poses":
        args.out = light_field_path(args.out, args.format)
    if os.path.exists(args.out) and not args.overwrite:
        raise ValueError(f"{args.out}: exists; expected a new path (or --overwrite)")
    if args.kind == "poses":
        if args.poses < 2:
            raise ValueError(f"--poses {args.poses}; expected at least 2 camera poses")
        write_poses(args)
        print(f"poses: {args.poses} light fields of {shape_of(args)} -> {args.out}/ ({args.format}); "
              f"try: liff sfm {args.out} --workspace ws --preprocess")
        return 0
    lf, truth = render(args)
    if args.format == "npz":
        arrays = ({"blobs": np.array([[b["x"], b["y"], b["radius"], b["slope"], b["intensity"]]
                                      for b in truth["blobs"]])}
                  if "blobs" in truth else {"slope_map": truth["slope_map"]})
        write_light_field(args.out, lf, "npz", arrays)
    else:
        write_light_field(args.out, lf, args.format, {})
        write_truth(args.out.rstrip(os.sep), truth)
    hint = f"; read it with --lenslet {lf.shape[0]}" if args.format == "eslf" else ""
    print(f"{args.kind}: {lf.shape} light field -> {args.out} ({args.format}{hint})")
    return 0
