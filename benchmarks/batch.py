"""Batch throughput, Dask's overhead per task, and the paper's dataset on 1, 8 and 64
machines (issue 14's targets), on Illum-size light fields.

    python benchmarks/batch.py [--count 24] [--rounds 3]     # needs pip install .[dask]

Each light field (11x11 views of 376x541, uint8, as .npy) is one task: read, detect,
write the .npz (liff.batch.run_task, what `liff detect` runs). In every round, the
same tasks run on: one local worker with one LiFF thread; one with both cores; two
local worker processes of one thread each (`liff detect --workers 2`); and a Dask
LocalCluster of two one-thread worker processes (`--scheduler`), started once before
the rounds. The load of this shared machine drifts, so rounds interleave the set-ups
and the figures are medians over rounds; the load average before each run is printed.

Besides wall times, each task reports its own seconds and CPU seconds (liff.batch's
Outcome). A set-up's gap per task, wall x workers / tasks - mean task seconds, is the
time a worker spent not running a task (scheduling, transfers, the tail of the run);
Dask's overhead per task is its gap less the local pool's, in the same round.
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


def timed_run(name: str, tasks: list, client) -> tuple:
    """(wall seconds, task seconds, task CPU seconds) of one set-up over ``tasks``;
    checks that every task succeeded."""
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
    return wall, sum(o.seconds for o in outcomes), sum(o.cpu_seconds for o in outcomes)


SETUPS = ("local, 1 worker x 1 thread", "local, 1 worker x 2 threads",
          "local, 2 workers x 1 thread", "dask, 2 workers x 1 thread")


WORKERS = {SETUPS[0]: 1, SETUPS[1]: 1, SETUPS[2]: 2, SETUPS[3]: 2}


def report(runs: dict, count: int, liff_1: float, liff_2: float, startup: float) -> None:
    """Prints the table and the targets from ``runs``: set-up -> list of (wall, task
    seconds, task CPU seconds, load average), one per round."""
    median = {name: statistics.median(r[0] for r in rows) for name, rows in runs.items()}
    gap = {name: statistics.median(r[0] * WORKERS[name] / count - r[1] / count for r in rows)
           for name, rows in runs.items()}
    cpu = {name: statistics.median(r[2] / count for r in rows) for name, rows in runs.items()}
    base = median[SETUPS[0]]
    print(f"\n{count} light fields of {ILLUM_SHAPE} (uint8 .npy); medians over "
          f"{len(runs[SETUPS[0]])} rounds")
    print("| set-up | seconds | light fields / s | vs 1 x 1 | CPU s / light field | gap s / task "
          "| rounds (s, load average before) |")
    print("|---|---|---|---|---|---|---|")
    for name in SETUPS:
        rounds = ", ".join(f"{r[0]:.1f} ({r[3]:.1f})" for r in runs[name])
        print(f"| {name} | {median[name]:.1f} | {count / median[name]:.2f} | "
              f"{base / median[name]:.2f}x | {cpu[name]:.2f} | {gap[name]:.3f} | {rounds} |")
    pool, dask = SETUPS[2], SETUPS[3]
    per_round = [(d[0] - p[0]) * 2 / count for d, p in zip(runs[dask], runs[pool])]
    overhead = statistics.median(d[0] * 2 / count - d[1] / count - (p[0] * 2 / count - p[1] / count)
                                 for d, p in zip(runs[dask], runs[pool]))
    print(f"\nLiFF's own time per light field (detectAndCompute, best of 3): {liff_1:.3f} s on "
          f"1 thread, {liff_2:.3f} s on 2")
    print(f"throughput, 2 local workers / 1 worker (1 thread each) = {base / median[pool]:.2f}x "
          f"(target >= 1.8); / 1 worker on both cores = {median[SETUPS[1]] / median[pool]:.2f}x")
    print(f"Dask overhead per task (its gap less the local pool's, median over rounds) = "
          f"{overhead * 1000:.0f} ms = {100 * overhead / liff_1:.1f}% of LiFF's own time (target "
          f"<= 5%); wall-time difference per task, by round: "
          f"{', '.join(f'{1000 * d:.0f} ms' for d in per_round)}; LocalCluster start-up "
          f"{startup:.1f} s (once per run)")
    per_light_field = cpu[pool]  # CPU seconds per light field, reading and writing included
    print(f"\nmeasured cost: {per_light_field:.2f} CPU seconds per light field (read, detect, "
          f"write; one thread); the paper's {PAPER_LIGHT_FIELDS} light fields, "
          f"{CORES_PER_MACHINE} cores per machine, one one-thread Dask worker per core, Dask's "
          "overhead included, files on storage that keeps up:")
    for machines in (1, 8, 64):
        seconds = PAPER_LIGHT_FIELDS * (per_light_field + max(overhead, 0)) / (
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
            runs = {name: [] for name in SETUPS}
            for r in range(args.rounds):
                for i, name in enumerate(SETUPS):
                    out = os.path.join(work, f"out{r}{i}")
                    load = os.getloadavg()[0]
                    runs[name].append(timed_run(name, tasks_into(paths, out), client) + (load,))
                    print(f"round {r + 1}, {name}: {runs[name][-1][0]:.1f} s (load average "
                          f"{load:.1f} before)", flush=True)
    report(runs, args.count, liff_1, liff_2, startup)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
