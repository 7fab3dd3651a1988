"""Two builds of liff against each other, interleaved (issue: speed at the hardware's pace).

A change to the core that keeps every result should show its worth as time saved; on a
shared machine the absolute times drift by 5-15% within minutes, so the two builds run
in turns, each round a fresh process per build, and what counts is the ratio of the
medians over many rounds.

    python benchmarks/ab_builds.py --before /path/to/old/python --after python

--before / --after: folders holding a built ``liff`` package (a checkout's ``python``
folder with its ``_core`` module, or a site-packages). Scenes, default parameters:
benchmarks/lightfields.py's Illum-size textured scene (11x11 views of 376x541, float
grey) and HCI cotton (../shared/data/hci/cotton, uint8 colour; skipped when absent).
Each process times ``--calls`` detectAndCompute calls after one untimed call (the
working memory is kept from call to call, as in a user's loop) and reports their
median. Printed per scene and thread count: each build's median over the rounds, the
ratio after / before, and the spread of the per-round ratios.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from lightfields import COTTON

HERE = Path(__file__).resolve().parent

_ONE_BUILD = """
import json, statistics, sys, time
sys.path.insert(0, sys.argv[1])
import liff
from lightfields import ILLUM_SHAPE, layered_light_field
scene, threads, calls = sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
if scene == "illum":
    lf = layered_light_field(ILLUM_SHAPE)
else:
    import liff.io
    lf = liff.io.read_light_field(sys.argv[5]).light_field
liff.setNumThreads(threads)
detector = liff.LiFF.create()
keypoints, _ = detector.detectAndCompute(lf, None)
times = []
for _ in range(calls):
    start = time.perf_counter()
    detector.detectAndCompute(lf, None)
    times.append(time.perf_counter() - start)
print(json.dumps({"median": statistics.median(times), "features": len(keypoints),
                  "liff": liff.__file__}))
"""


def one_run(package: str, scene: str, threads: int, calls: int) -> dict:
    env = dict(os.environ, PYTHONPATH=str(HERE))
    out = subprocess.run([sys.executable, "-c", _ONE_BUILD, package, scene, str(threads),
                          str(calls), str(COTTON)],
                         capture_output=True, text=True, check=True, env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", required=True, help="folder holding the old build's liff")
    parser.add_argument("--after", required=True, help="folder holding the new build's liff")
    parser.add_argument("--rounds", type=int, default=14)
    parser.add_argument("--calls", type=int, default=3, help="timed calls per process")
    parser.add_argument("--threads", type=int, nargs="+", default=[1])
    args = parser.parse_args()
    builds = {"before": str(Path(args.before).resolve()), "after": str(Path(args.after).resolve())}
    scenes = ["illum"] + (["cotton"] if COTTON.is_dir() else [])
    if len(scenes) == 1:
        print(f"(cotton skipped: {COTTON} not found)")
    for scene in scenes:
        for threads in args.threads:
            medians: dict = {"before": [], "after": []}
            features, modules = {}, {}
            for _ in range(args.rounds):
                for name, package in builds.items():
                    r = one_run(package, scene, threads, args.calls)
                    medians[name].append(r["median"])
                    features[name], modules[name] = r["features"], r["liff"]
            if scene == scenes[0] and threads == args.threads[0]:
                print("liff imported from: " + ", ".join(f"{k} {v}" for k, v in modules.items()))
            ratios = [a / b for a, b in zip(medians["after"], medians["before"])]
            before, after = statistics.median(medians["before"]), statistics.median(medians["after"])
            print(f"{scene}, {threads} thread(s), {args.rounds} rounds x {args.calls} calls: "
                  f"before {before:.3f} s ({features['before']} features), after {after:.3f} s "
                  f"({features['after']} features); after / before {after / before:.3f} "
                  f"(per-round ratios {min(ratios):.3f} - {max(ratios):.3f})")


if __name__ == "__main__":
    main()
