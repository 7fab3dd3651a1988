"""``liff synth KIND --out PATH``: synthetic light fields with their ground truth."""

from __future__ import annotations

import argparse
import json
import os
from dataclasses import asdict

import numpy as np

from .. import synthetic

KINDS = ("disks", "layers")
FORMATS = ("npz", "views", "eslf", "mosaic")


def add_parser(sub) -> None:
    p = sub.add_parser(
        "synth", help="write a synthetic light field with known answers",
        description="disks: the paper's noise scene (26 disks, contrast 0.1, slopes in "
                    "[-1, 1]); layers: three textured fronto-parallel layers with partial "
                    "occlusion. npz keeps float32 and the ground truth in one file; image "
                    "formats are written as 16-bit PNG with the truth in <out>.truth.json "
                    "(disks) or <out>.slopes.npy (layers).")
    p.add_argument("kind", choices=KINDS)
    p.add_argument("--out", required=True, help="output file (npz, eslf, mosaic) or folder (views)")
    p.add_argument("--format", choices=FORMATS, default="npz", help="default npz")
    p.add_argument("--views", type=int, default=9, help="T = S (default 9)")
    p.add_argument("--size", type=int, nargs=2, default=(256, 256), metavar=("V", "U"),
                   help="view size (default 256 256)")
    p.add_argument("--noise", type=float, default=0.0, help="noise variance (default 0)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--overwrite", action="store_true", help="replace an existing output")
    p.set_defaults(run=run)


def render(args: argparse.Namespace):
    """(light field float32 (T, S, V, U), truth dict of arrays / lists)."""
    shape = (args.views, args.views, args.size[0], args.size[1])
    if args.kind == "disks":
        blobs = synthetic.paper_disks(shape=shape, seed=args.seed)
        lf = synthetic.render_disks(blobs, shape, noise_variance=args.noise, seed=args.seed)
        return lf.astype(np.float32), {"blobs": [asdict(b) for b in blobs]}
    scene = synthetic.textured_layers(shape, seed=args.seed, noise_variance=args.noise)
    return scene.light_field, {"slope_map": scene.slope_map}


def run(args: argparse.Namespace) -> int:
    from .. import io

    if args.format == "npz" and not args.out.endswith(".npz"):
        args.out += ".npz"  # numpy would append it anyway
    if os.path.exists(args.out) and not args.overwrite:
        raise ValueError(f"{args.out}: exists; expected a new path (or --overwrite)")
    lf, truth = render(args)
    if args.format == "npz":
        arrays = {"light_field": lf}
        if "blobs" in truth:
            arrays["blobs"] = np.array([[b["x"], b["y"], b["radius"], b["slope"], b["intensity"]]
                                        for b in truth["blobs"]])
        else:
            arrays["slope_map"] = truth["slope_map"]
        np.savez_compressed(args.out, **arrays)
    else:
        image = np.round(np.clip(lf, 0, 1) * 65535).astype(np.uint16)
        if args.format == "views":
            io.write_views(args.out, image)
        elif args.format == "eslf":
            io.write_eslf(args.out, image)
        else:
            io.write_mosaic(args.out, image)
        base = args.out.rstrip(os.sep)
        if "blobs" in truth:
            with open(base + ".truth.json", "w") as f:
                json.dump(truth, f, indent=1)
        else:
            np.save(base + ".slopes.npy", truth["slope_map"])
    hint = f"; read it with --lenslet {args.views}" if args.format == "eslf" else ""
    print(f"{args.kind}: {lf.shape} light field -> {args.out} ({args.format}{hint})")
    return 0
