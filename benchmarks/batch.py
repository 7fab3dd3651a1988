"""Batch throughput, Dask's overhead per task, and the paper's dataset on 1, 8 and 64
machines (issue 14's targets), on Illum-size light fields.

    python benchmarks/batch.py [--count 24] [--rounds 3]     # needs pip install .[dask]

Each light field (11x11 views of 376x541, uint8, as .npy) is one task: read, detect,
write the .npz (liff.batch.run_task, what `liff detect` runs). In every round, the
same tasks run on: one local worker with one LiFF thread; one with both cores; two
local worker processes of one thread each (`liff detect --workers 2`); and a Dask
LocalCluster of two one-thread worker processes (`--scheduler`, Dask's defaults), as
liff runs it (the workers' statistical profiler paused for the run) and with the
profiler kept running (``worker_profiler=True``). Each cluster is started before its run
and closed after (outside the timings), so that no idle Dask process shares the
machine with the other set-ups. The load of this shared machine drifts, so rounds
interleave the set-ups and the figures are medians over rounds; the load average
before each run is printed.

First, the time and size of one light field's feature file as `liff detect` writes it,
against numpy's savez_compressed of the same arrays; and the processor time and page
faults of detections in one process with the core's working memory kept between calls
(the default) and without, under glibc's defaults and Dask's nanny settings, in the main
thread and in another one (as a Dask task runs). Besides wall times, each task
reports its own seconds and CPU seconds (liff.batch's Outcome). A set-up's gap per task,
wall x workers / tasks - mean task seconds, is the time a worker spent not running a
task (scheduling, transfers, the tail of the run).
Dask's overhead per task is the wall-time difference to the local pool in the same
round, times workers / tasks: all it costs, its processes' own work competing with the
tasks included; printed beside it, the part between tasks (the gaps' difference) and
the CPU time the task's process spent beyond the pool's (Dask's own threads); and
Dask's own CPU per task measured directly: the processor time of the worker
processes' threads other than the task threads (/proc/self/task), and of this process
(the client, and the LocalCluster's scheduler, which runs in it), which the load of a
shared machine disturbs far less than wall times.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from contextlib import ExitStack

import numpy as np

import liff
from liff import batch, feature_file
from liff.cli import common
from liff.keypoint_rows import keypoints_to_rows

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


def feature_file_costs(path: str, folder: str, repeats: int = 3) -> None:
    """Prints the time and size of one light field's feature file as `liff detect`
    writes it (liff.feature_file.save_features, zlib level COMPRESSION_LEVEL) against
    numpy's savez_compressed (level 6) of the same arrays."""
    lf = np.load(path)
    keypoints, descriptors = liff.LiFF.create().detectAndCompute(lf, None)
    features = feature_file.Features(tuple(keypoints), descriptors, feature_file.centre_view(lf))
    arrays = dict(keypoints=keypoints_to_rows(keypoints)[:, :6],
                  slopes=features.slopes, descriptors=descriptors,
                  centre_view=features.centre_view)
    writers = {f"save_features (zlib level {feature_file.COMPRESSION_LEVEL})":
               lambda target: feature_file.save_features(target, features),
               "numpy savez_compressed (zlib level 6)":
               lambda target: np.savez_compressed(target, **arrays)}
    print(f"feature file of one light field ({len(keypoints)} features), best of {repeats}:")
    for name, write in writers.items():
        target = os.path.join(folder, "cost.npz")
        best = np.inf
        for _ in range(repeats):
            start = time.perf_counter()
            write(target)
            best = min(best, time.perf_counter() - start)
        print(f"  {name}: {best:.3f} s, {os.path.getsize(target) / 2**20:.2f} MiB")


# One-thread detections of a light field in a fresh process, in the main thread or in
# another one (as a Dask task runs), with the core's working memory kept between calls
# (the default) or not: CPU seconds (user, system) and page faults of each, as JSON.
_ALLOCATOR_SCRIPT = """
import json, resource, sys, threading
import numpy as np
import liff
liff.setWorkingMemoryReuse(sys.argv[2] == "kept")
lf = np.load(sys.argv[1])
liff.setNumThreads(1)
detector = liff.LiFF.create()
calls = []
def detect():
    for _ in range(4):
        before = resource.getrusage(resource.RUSAGE_THREAD)
        detector.detectAndCompute(lf, None)
        after = resource.getrusage(resource.RUSAGE_THREAD)
        calls.append((after.ru_utime - before.ru_utime, after.ru_stime - before.ru_stime,
                      after.ru_minflt - before.ru_minflt))
if sys.argv[3] == "thread":
    worker = threading.Thread(target=detect)
    worker.start()
    worker.join()
else:
    detect()
print(json.dumps(calls))
"""


def allocator_costs(path: str) -> None:
    """Prints what detecting light field after light field costs a process with the
    core's working memory kept between calls (the default) and without, under glibc's
    defaults and under Dask's nanny settings (MALLOC_TRIM_THRESHOLD_=65536), in fresh
    processes, alternating, in the main thread and in another thread (where a Dask task
    runs): the first call's page faults, and the median user and system CPU seconds and
    page faults of the later ones."""
    nanny = dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536")
    setups = [(f"{memory}, {allocator}, {where} thread", mode, where, env)
              for allocator, env in (("glibc defaults", dict(os.environ)), ("Dask nanny", nanny))
              for where in ("main", "another")
              for memory, mode in (("kept", "kept"), ("not kept", "off"))]
    costs = {name: [] for name, *_ in setups}
    for _ in range(2):
        for name, mode, where, env in setups:
            out = subprocess.run([sys.executable, "-c", _ALLOCATOR_SCRIPT, path, mode,
                                  "thread" if where == "another" else "main"],
                                 capture_output=True, text=True, check=True, env=env)
            costs[name].append(json.loads(out.stdout.strip().splitlines()[-1]))
    print("one-thread detections in one process: working memory kept or not; first call's "
          "page faults (median of 2 processes), later calls' median of 6:")
    for name, runs in costs.items():
        first = statistics.median(run[0][2] for run in runs)
        later = [c for run in runs for c in run[1:]]
        user, system, faults = (statistics.median(c[i] for c in later) for i in range(3))
        print(f"  {name}: first call {first:.0f} page faults; later calls user {user:.3f} s, "
              f"system {system:.3f} s, {faults:.0f} page faults ({100 * faults / first:.1f}% "
              "of the first)")


def tasks_into(paths: list, folder: str) -> list:
    parameters = {p.name: p.default for p in liff.PARAMETERS}
    return [batch.Task(p, os.path.join(folder, os.path.basename(p)[:-4] + ".npz"), None, {},
                       False, parameters) for p in paths]


def dask_thread_cpu() -> float:
    """CPU seconds so far of this process's threads other than its task threads (those
    of Dask's executor): on a Dask worker, Dask's own work (the event loop in the main
    thread: messages, heartbeats, the memory monitor, the profiler's sampling)."""
    import threading

    tick = os.sysconf("SC_CLK_TCK")
    tasks = {t.native_id for t in threading.enumerate() if "Dask-Default-Threads" in t.name}
    total = 0.0
    for tid in os.listdir("/proc/self/task"):
        if int(tid) in tasks:
            continue
        with open(f"/proc/self/task/{tid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()  # (after the thread's name)
        total += (int(fields[11]) + int(fields[12])) / tick  # utime + stime
    return total


def timed_run(name: str, tasks: list, client) -> tuple:
    """(wall seconds, task seconds, task CPU seconds, Dask's own CPU seconds (in the
    workers, and in this process: client and LocalCluster's scheduler) or zeros) of one
    set-up over ``tasks``; checks that every task succeeded."""
    start = time.perf_counter()
    dask_cpu = (0.0, 0.0)
    if name.startswith("dask"):
        before = client.run(dask_thread_cpu)  # (liff is imported by the first task, as locally)
        start, here = time.perf_counter(), time.process_time()
        outcomes = batch.run(tasks, client, worker_profiler=name == SETUPS[4])
        wall, here = time.perf_counter() - start, time.process_time() - here
        after = client.run(dask_thread_cpu)
        dask_cpu = (sum(after[w] - before[w] for w in after), here)
    else:
        workers, threads = {"local, 1 worker x 1 thread": (1, 1), "local, 1 worker x 2 threads": (1, 2),
                            "local, 2 workers x 1 thread": (2, 1)}[name]
        liff.setNumThreads(threads)
        outcomes = common.run_batch(batch.run_task, [(t,) for t in tasks], workers, "bench", str)[0]
        wall = time.perf_counter() - start
    failed = [o for o in outcomes if o is None or o.status != "done"]
    if failed:
        raise RuntimeError(f"{name}: {len(failed)} task(s) failed: {failed[:1]}")
    return wall, sum(o.seconds for o in outcomes), sum(o.cpu_seconds for o in outcomes), dask_cpu


SETUPS = ("local, 1 worker x 1 thread", "local, 1 worker x 2 threads",
          "local, 2 workers x 1 thread", "dask, 2 workers x 1 thread",
          "dask, 2 workers x 1 thread, profiler kept")
#: Dask configuration of each Dask set-up's cluster: Dask's defaults in both; the second
#: keeps the workers' statistical profiler running during the run, which liff pauses
#: (it samples the task's thread from the worker's event loop every 10 ms; liff's
#: _dask_workers). (Earlier runs' fifth set-ups: workers started with MALLOC_ARENA_MAX=1,
#: no better once a thread's memory was kept (then by tuning glibc, now by the core
#: itself); the profiler turned off in the workers' configuration, as fast as pausing it.)
DASK_CONFIG = {SETUPS[3]: {}, SETUPS[4]: {}}


WORKERS = {SETUPS[0]: 1, SETUPS[1]: 1, SETUPS[2]: 2, SETUPS[3]: 2, SETUPS[4]: 2}


def report(runs: dict, count: int, liff_1: float, liff_2: float, startup: float) -> None:
    """Prints the table and the targets from ``runs``: set-up -> list of (wall, task
    seconds, task CPU seconds, Dask's own CPU seconds, load average), one per round."""
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
        rounds = ", ".join(f"{r[0]:.1f} ({r[4]:.1f})" for r in runs[name])
        print(f"| {name} | {median[name]:.1f} | {count / median[name]:.2f} | "
              f"{base / median[name]:.2f}x | {cpu[name]:.2f} | {gap[name]:.3f} | {rounds} |")
    pool = SETUPS[2]
    print(f"\nLiFF's own time per light field (detectAndCompute, best of 3): {liff_1:.3f} s on "
          f"1 thread, {liff_2:.3f} s on 2")
    print(f"throughput, 2 local workers / 1 worker (1 thread each) = {base / median[pool]:.2f}x "
          f"(target >= 1.8); / 1 worker on both cores = {median[SETUPS[1]] / median[pool]:.2f}x")
    overheads = {}
    for dask in SETUPS[3:]:
        # Per task, against the local pool of as many one-thread workers in the same round:
        # the wall-time difference (all of Dask's cost: scheduling, and its processes'
        # own work competing with the tasks; the noisiest), the part of it between tasks
        # (gaps), and the CPU time the task's process spent beyond the pool's (Dask's
        # threads in the worker process: event loop, profiler).
        pairs = list(zip(runs[dask], runs[pool]))
        per_round = [(d[0] - p[0]) * 2 / count for d, p in pairs]
        gaps = [(d[0] * 2 - d[1] - (p[0] * 2 - p[1])) / count for d, p in pairs]
        cpus = [(d[2] - p[2]) / count for d, p in pairs]
        overheads[dask] = statistics.median(per_round)
        print(f"{dask}: overhead per task = {1000 * overheads[dask]:.0f} ms = "
              f"{100 * overheads[dask] / liff_1:.1f}% of LiFF's own time (target <= 5%; "
              f"wall-time difference to the local pool, median over rounds; by round "
              f"{', '.join(f'{1000 * d:.0f}' for d in per_round)} ms); between tasks "
              f"{', '.join(f'{1000 * g:.0f}' for g in gaps)} ms; CPU in the task's process "
              f"beyond the pool's {', '.join(f'{1000 * c:.0f}' for c in cpus)} ms")
        # Dask's own processor time in the workers (threads other than the task's),
        # which the shared machine's load disturbs far less than wall times.
        own = [d[3][0] / count for d in runs[dask]]
        here = [d[3][1] / count for d in runs[dask]]
        print(f"  Dask's own CPU per task: in the workers {1000 * statistics.median(own):.0f} ms "
              f"= {100 * statistics.median(own) / liff_1:.1f}% of LiFF's own time (median; by "
              f"round {', '.join(f'{1000 * o:.0f}' for o in own)} ms); in the scheduler and "
              f"client (this process) {1000 * statistics.median(here):.0f} ms (by round "
              f"{', '.join(f'{1000 * h:.0f}' for h in here)} ms)")
    print(f"LocalCluster start-up {startup:.1f} s (median; once per run, outside the timings)")
    overhead = overheads[SETUPS[3]]  # `dask worker ADDRESS` as liff runs tasks on it
    per_light_field = cpu[pool]  # CPU seconds per light field, reading and writing included
    print(f"\nmeasured cost: {per_light_field:.2f} CPU seconds per light field (read, detect, "
          f"write; one thread); the paper's {PAPER_LIGHT_FIELDS} light fields, "
          f"{CORES_PER_MACHINE} cores per machine, one one-thread Dask worker per core, "
          "Dask's overhead included, files on storage that keeps up:")
    for machines in (1, 8, 64):
        seconds = PAPER_LIGHT_FIELDS * (per_light_field + max(overhead, 0)) / (
            machines * CORES_PER_MACHINE)
        print(f"  {machines:2d} machine(s): {seconds / 60:6.1f} min")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=24, help="light fields (default 24)")
    parser.add_argument("--rounds", type=int, default=3, help="rounds (default 3)")
    args = parser.parse_args(argv)
    import dask
    import distributed

    with tempfile.TemporaryDirectory() as work:
        paths = write_inputs(work, args.count)
        liff.setNumThreads(1)
        feature_file_costs(paths[0], work)
        allocator_costs(paths[0])
        liff_1, liff_2 = liff_seconds(paths[0], 1), liff_seconds(paths[0], 2)
        runs = {name: [] for name in SETUPS}
        startups = []
        for r in range(args.rounds):
            for i, name in enumerate(SETUPS):
                out = os.path.join(work, f"out{r}{i}")
                with ExitStack() as stack:
                    client = None
                    if name.startswith("dask"):
                        # A cluster only while its set-up runs: idle Dask processes
                        # (heartbeats, the nanny's memory monitor) would take CPU from
                        # the local set-ups' second worker, not from the first's.
                        start = time.perf_counter()
                        stack.enter_context(dask.config.set(DASK_CONFIG[name]))
                        cluster = stack.enter_context(distributed.LocalCluster(
                            n_workers=2, threads_per_worker=1, processes=True,
                            dashboard_address=":0"))
                        client = stack.enter_context(distributed.Client(cluster))
                        startups.append(time.perf_counter() - start)
                    load = os.getloadavg()[0]
                    runs[name].append(timed_run(name, tasks_into(paths, out), client) + (load,))
                print(f"round {r + 1}, {name}: {runs[name][-1][0]:.1f} s (load average "
                      f"{load:.1f} before)", flush=True)
    report(runs, args.count, liff_1, liff_2, statistics.median(startups))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
