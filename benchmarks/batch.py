"""Batch throughput, Dask's overhead per task, and the paper's dataset on 1, 8 and 64
machines (issue 14's targets), on Illum-size light fields.

    python benchmarks/batch.py [--count 24] [--rounds 3]     # needs pip install .[dask]

Each light field (11x11 views of 376x541, uint8, as .npy) is one task: read, detect,
write the .npz (liff.batch.run_task, what `liff detect` runs). In every round, the
same tasks run on: one local worker with one LiFF thread; one with both cores; two
local worker processes of one thread each (`liff detect --workers 2`); and a Dask
LocalCluster of two one-thread worker processes (`--scheduler`), started once before
the rounds. The load of this shared machine drifts, so rounds interleave the set-ups
and the figures are medians over rounds.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time

import numpy as np

import liff
from liff import batch
from liff.cli import common

sys.path.insert(0, os.path.dirname(__file__))
from lightfields import ILLUM_SHAPE, layered_light_field  # noqa: E402

PAPER_LIGHT_FIELDS = 4211  # the paper's SfM dataset
CORES_PER_MACHINE = 2


def write_inputs(folder: str, count: int) -> list:
    """``count`` different Illum-size uint8 light fields: 4 scenes, flipped and shifted."""
    scenes = [np.round(np.clip(layered_light_field(seed=s), 0, 1) * 255).astype(np.uint8)
              for s in range(4)]
    paths = []
    for i in range(count):
        lf = np.roll(scenes[i % 4], 17 * (i // 4), axis=3)
        paths.append(os.path.join(folder, f"lf{i:03d}.npy"))
        np.save(paths[-1], lf[:, :, :, ::-1] if i % 8 >= 4 else lf)
    return paths


def liff_seconds(path: str, threads: int, repeats: int = 3) -> float:
    """LiFF's own time (detectAndCompute only) on one light field, best of ``repeats``."""
    lf = np.load(path)
    liff.setNumThreads(threads)
    detector = liff.LiFF.create()
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        detector.detectAndCompute(lf, None)
        best = min(best, time.perf_counter() - start)
    return best


def tasks_into(paths: list, folder: str) -> list:
    parameters = {p.name: p.default for p in liff.PARAMETERS}
    return [batch.Task(p, os.path.join(folder, os.path.basename(p)[:-4] + ".npz"), None, {},
                       False, parameters) for p in paths]


def timed_run(name: str, tasks: list, client) -> float:
    """Wall time of one set-up over ``tasks``; checks that every task succeeded."""
    start = time.perf_counter()
    if name == "dask, 2 workers x 1 thread":
        outcomes = batch.run(tasks, client)
    else:
        workers, threads = {"local, 1 worker x 1 thread": (1, 1), "local, 1 worker x 2 threads": (1, 2),
                            "local, 2 workers x 1 thread": (2, 1)}[name]
        liff.setNumThreads(threads)
        outcomes = common.run_batch(batch.run_task, [(t,) for t in tasks], workers, "bench", str)[0]
    wall = time.perf_counter() - start
    failed = [o for o in outcomes if o is None or o.status != "done"]
    if failed:
        raise RuntimeError(f"{name}: {len(failed)} task(s) failed: {failed[:1]}")
    return wall


SETUPS = ("local, 1 worker x 1 thread", "local, 1 worker x 2 threads",
          "local, 2 workers x 1 thread", "dask, 2 workers x 1 thread")


def report(walls: dict, count: int, liff_1: float, liff_2: float, startup: float) -> None:
    median = {name: statistics.median(times) for name, times in walls.items()}
    base = median[SETUPS[0]]
    print(f"\n{count} light fields of {ILLUM_SHAPE} (uint8 .npy); medians over "
          f"{len(walls[SETUPS[0]])} rounds")
    print("| set-up | seconds | light fields / s | vs 1 worker x 1 thread | rounds |")
    print("|---|---|---|---|---|")
    for name in SETUPS:
        rounds = ", ".join(f"{t:.1f}" for t in walls[name])
        print(f"| {name} | {median[name]:.1f} | {count / median[name]:.2f} | "
              f"{base / median[name]:.2f}x | {rounds} |")
    pool, dask = median[SETUPS[2]], median[SETUPS[3]]
    overhead = (dask - pool) * 2 / count
    print(f"\nLiFF's own time per light field (detectAndCompute, best of 3): {liff_1:.3f} s on "
          f"1 thread, {liff_2:.3f} s on 2")
    print(f"throughput, 2 local workers / 1 worker (1 thread each) = {base / pool:.2f}x "
          f"(target >= 1.8); / 1 worker on both cores = {median[SETUPS[1]] / pool:.2f}x")
    print(f"Dask overhead per task = (dask - local pool) x 2 workers / {count} = "
          f"{overhead * 1000:.0f} ms = {100 * overhead / liff_1:.1f}% of LiFF's own time "
          f"(target <= 5%); LocalCluster start-up {startup:.1f} s (once per run)")
    per_light_field = pool * 2 / count  # core-seconds per light field, I/O included
    print(f"\nmeasured cost: {per_light_field:.2f} core-seconds per light field (read, detect, "
          f"write); the paper's {PAPER_LIGHT_FIELDS} light fields, {CORES_PER_MACHINE} cores "
          "per machine, one Dask worker process per core, Dask's overhead included:")
    for machines in (1, 8, 64):
        seconds = PAPER_LIGHT_FIELDS * (per_light_field + max(overhead, 0) * 2) / (
            machines * CORES_PER_MACHINE)
        print(f"  {machines:2d} machine(s): {seconds / 60:6.1f} min")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=24, help="light fields (default 24)")
    parser.add_argument("--rounds", type=int, default=3, help="rounds (default 3)")
    args = parser.parse_args(argv)
    import distributed

    with tempfile.TemporaryDirectory() as work:
        paths = write_inputs(work, args.count)
        liff_1, liff_2 = liff_seconds(paths[0], 1), liff_seconds(paths[0], 2)
        start = time.perf_counter()
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=":0") as cluster, \
                distributed.Client(cluster) as client:
            startup = time.perf_counter() - start
            walls = {name: [] for name in SETUPS}
            for r in range(args.rounds):
                for i, name in enumerate(SETUPS):
                    out = os.path.join(work, f"out{r}{i}")
                    walls[name].append(timed_run(name, tasks_into(paths, out), client))
                    print(f"round {r + 1}, {name}: {walls[name][-1]:.1f} s", flush=True)
    report(walls, args.count, liff_1, liff_2, startup)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
