"""The ``liff`` console command."""

from __future__ import annotations

import argparse
import sys


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="liff", description="Light field features in scale and depth.")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="detect features on a built-in synthetic light field")
    demo.add_argument("--out", default="liff-demo", help="output folder (default: liff-demo)")
    demo.add_argument("--noise", type=float, default=1e-3, help="noise variance (default 1e-3)")
    args = parser.parse_args(argv)
    if args.command == "demo":
        from .demo import run_demo

        return run_demo(args.out, noise_variance=args.noise)
    return 2


if __name__ == "__main__":
    sys.exit(main())
