"""``liff demo --out DIR``: the main job on a built-in example (the README's first command)."""

from __future__ import annotations

import argparse


def add_parser(sub) -> None:
    p = sub.add_parser("demo", help="detect features on a built-in synthetic light field")
    p.add_argument("--out", default="liff-demo", help="output folder (default: liff-demo)")
    p.add_argument("--noise", type=float, default=1e-3, help="noise variance (default 1e-3)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..demo import run_demo

    return run_demo(args.out, noise_variance=args.noise)
