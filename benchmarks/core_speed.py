"""The core's speed against cv2.SIFT, its thread scaling and its working memory
(issue: speed at the hardware's pace).

Scenes, default parameters (the automatic slope range): benchmarks/lightfields.py's
Illum-size textured scene (11x11 views of 376x541, float grey) and HCI cotton (9x9 views
of 512x512, uint8 colour, as read from ../shared/data/hci/cotton; skipped when absent).
For each scene:

1. One thread, LiFF detectAndCompute on the light field against cv2.SIFT
   detectAndCompute on the centre view (as the user has it: uint8, colour for cotton),
   interleaved in rounds; the ratio is the median of the per-round ratios. Also with
   firstOctave=0.
2. Two threads against one (LiFF), interleaved likewise.
3. Where the time goes, one thread, from the core's profiler: each stage's
   thread-seconds and the share of it inside parallel loops; the time outside any
   parallel loop (serial); and from every parallel loop's tasks (each index timed) the
   predicted wall time at P threads, serial + sum over loops of the greedy longest-first
   schedule of its tasks on P threads (which ignores memory bandwidth and the
   scheduler's own cost: an upper bound of the speed-up), as a speed-up T1 / T(P).
4. Repeated SIFT (cv2.SIFT on every view) against LiFF, one thread.
   Also: the automatic slope range's cost, the default call against one given by hand
   the slopes the survey chose; and the one-thread seconds of each parallel loop.
5. In fresh processes: the peak memory a default detection adds to the process
   (its peak resident size, VmHWM, reset before the call, less its resident size
   then) and the page faults of a second detection in a
   worker thread, against the first, with glibc's defaults and with Dask's nanny
   setting (MALLOC_TRIM_THRESHOLD_=65536).

Usage:  python benchmarks/core_speed.py [--rounds 5] [--quick]
(--quick: the Illum-size scene only, 3 rounds, no subprocesses.)
"""

from __future__ import annotations

import argparse
import heapq
import json
import os
import platform
import statistics
import subprocess
import sys
import time

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import liff  # noqa: E402
import liff._core as core  # noqa: E402
from lightfields import COTTON, ILLUM_SHAPE, layered_light_field  # noqa: E402

THREADS = (1, 2, 4, 8, 16, 32)


def scenes(quick: bool) -> dict:
    out = {"Illum-size textured 11x11x376x541": layered_light_field(ILLUM_SHAPE)}
    if not quick and COTTON.is_dir():
        from liff.io import read_light_field

        out["HCI cotton 9x9x512x512 (uint8 BGR)"] = read_light_field(str(COTTON)).light_field
    elif not quick:
        print(f"(HCI cotton not found at {COTTON}: skipped)")
    return out


def centre_view(lf: np.ndarray) -> np.ndarray:
    """The centre view as cv2.SIFT would be given it: uint8 as it is, floats in [0, 1]
    scaled to uint8."""
    view = lf[lf.shape[0] // 2, lf.shape[1] // 2]
    if view.dtype != np.uint8:
        view = np.clip(view * 255.0 + 0.5, 0, 255).astype(np.uint8)
    return view


def seconds(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def interleaved(rounds: int, **calls) -> dict:
    """Each call once per round, in turn; the list of seconds of each."""
    times = {name: [] for name in calls}
    for _ in range(rounds):
        for name, fn in calls.items():
            times[name].append(seconds(fn))
    return times


def median_ratio(a, b) -> float:
    return statistics.median(x / y for x, y in zip(a, b))


def lpt(tasks, threads: int) -> float:
    """Wall time of the greedy longest-first schedule of `tasks` on `threads`."""
    loads = [0.0] * threads
    for t in sorted(tasks, reverse=True):
        heapq.heapreplace(loads, loads[0] + t)
    return max(loads)


def profile(detector, lf, batch: int, repeats: int = 3):
    """Profiled one-thread calls with the loops of a ``batch``-thread call (slices built
    ``batch`` at once): the fastest call's (wall, stage seconds, their part inside
    loops, loops); the least time outside loops over the calls; and each loop's tasks,
    each task's least time over the calls (the calls run the same loops and tasks, and
    on a shared machine another process preempting a task makes it look long, which
    would make its loop look unbalanced)."""
    liff.setNumThreads(1)
    core._hooks.set_slice_batch(batch)
    runs = []
    try:
        detector.detectAndCompute(lf, None)  # warm: working memory, caches
        for _ in range(repeats):
            core._hooks.set_profiling(True)
            core._hooks.reset_profile()
            wall = seconds(lambda: detector.detectAndCompute(lf, None))
            runs.append((wall, core._hooks.stage_seconds(), core._hooks.stage_seconds(True),
                         core._hooks.parallel_loops()))
            core._hooks.set_profiling(False)
    finally:
        core._hooks.set_profiling(False)
        core._hooks.set_slice_batch(0)
    if len({tuple((n, len(t)) for n, _, t in r[3]) for r in runs}) != 1:
        raise RuntimeError("profiled calls ran different loops")
    loops = [(name, [min(r[3][i][2][j] for r in runs) for j in range(len(tasks))])
             for i, (name, _, tasks) in enumerate(runs[0][3])]
    # Time outside every loop, the least over the calls; the model's one-thread time is
    # that and every task's least time.
    serial = min(r[0] - sum(w for _, w, _ in r[3]) for r in runs)
    fastest = min(runs, key=lambda r: r[0])
    return fastest, serial, loops


def survey_cost(default, lf, rounds: int) -> None:
    """What the automatic slope range costs: the default call against a call given, by
    hand, the slices the default built (searched slopes and the unsearched guard at each
    end), interleaved. The hand-set call also searches the two guards, so the survey's
    share it gives is a lower bound."""
    used = list(default.getSlicesUsed())
    if len(used) < 2:
        return
    given = liff.LiFF.create(firstSlope=used[0], lastSlope=used[-1], numSlopes=len(used))
    given.detectAndCompute(lf, None)  # warm
    same = np.allclose(list(given.getSlicesUsed()), used, rtol=0, atol=1e-9)
    t = interleaved(rounds, auto=lambda: default.detectAndCompute(lf, None),
                    given=lambda: given.detectAndCompute(lf, None))
    ratio = median_ratio(t["auto"], t["given"])
    print(f"the automatic range against its {len(used)} slices given by hand "
          f"({'the same' if same else 'NOT the same'} slices built): {ratio:.2f}x, the survey at "
          f"least {100 * (1 - 1 / ratio):.0f}% of a default call")


def stage_model(detector, lf) -> None:
    """One-thread stage times, parallel shares and the predicted speed-ups."""
    (wall, stages, in_loops, loops), _, _ = profile(detector, lf, 1)
    loop_wall = sum(w for _, w, _ in loops)
    other = wall - sum(stages.values())
    other_in_loops = loop_wall - sum(in_loops.values())
    print(f"\none thread, profiled (each parallel task timed; fastest of 3 calls): wall "
          f"{wall:.3f} s, {len(loops)} parallel loops, {sum(len(t) for *_, t in loops)} tasks")
    print("| stage | one-thread seconds | share of the call | inside parallel loops |\n|---|---|---|---|")
    for name, s in list(stages.items()) + [("other (conversion, survey bookkeeping, sorting)", other)]:
        inside = in_loops.get(name, other_in_loops)
        print(f"| {name} | {s:.3f} | {100 * s / wall:.0f}% | {100 * inside / max(s, 1e-12):.0f}% |")
    serial = wall - loop_wall
    print(f"serial (outside every parallel loop): {serial:.3f} s = {100 * serial / wall:.1f}% of the call")
    by_loop = {}
    for name, _, tasks in loops:
        by_loop[name] = by_loop.get(name, 0.0) + sum(tasks)
    print("one-thread seconds by parallel loop: " + ", ".join(
        f"{name} {t:.3f}" for name, t in sorted(by_loop.items(), key=lambda kv: -kv[1])))
    # A P-thread call builds P slices at once (memory allowing): its loops have more
    # tasks. Profile that structure on one thread for each P, schedule its tasks on P.
    speedups, where = [], ""
    for p in THREADS[1:]:
        _, serial_p, loops_p = profile(detector, lf, p)
        one = serial_p + sum(sum(tasks) for _, tasks in loops_p)
        predicted = serial_p + sum(lpt(tasks, p) for _, tasks in loops_p)
        speedups.append(f"{p} threads {one / predicted:.1f}x")
        if p == 16:  # where the 16-thread time goes, loop by loop
            by_name = {}
            for name, tasks in loops_p:
                entry = by_name.setdefault(name, [0.0, 0.0])
                entry[0] += lpt(tasks, p)
                entry[1] += sum(tasks) / p
            where = f"serial {serial_p:.3f} s, " + ", ".join(
                f"{name} {t:.3f} s (ideal {ideal:.3f})"
                for name, (t, ideal) in sorted(by_name.items(), key=lambda kv: -kv[1][0]))
    print("predicted speed-up over one thread (a P-thread call's tasks, timed on one thread, "
          "greedily scheduled on P): " + ", ".join(speedups))
    print(f"predicted 16-thread time by loop (its schedule; all its tasks / 16): {where}")


_FRESH = """
import json, resource, sys, threading
import numpy as np
import liff
lf = np.load(sys.argv[1])
liff.setNumThreads(1)
out = {}
def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt
def status(field):  # kB, from /proc/self/status
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith(field + ":"))
def run():
    detector = liff.LiFF.create()
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # resets the peak resident size (VmHWM) to the current one
    before = status("VmRSS")
    f0 = faults(); detector.detectAndCompute(lf, None); f1 = faults()
    out["peak_added_mb"] = (status("VmHWM") - before) / 1024
    detector.detectAndCompute(lf, None); f2 = faults()
    out["first"], out["second"] = f1 - f0, f2 - f1
worker = threading.Thread(target=run)
worker.start(); worker.join()
print(json.dumps(out))
"""


def fresh_process_memory() -> None:
    import tempfile

    print("\nfresh process, one thread, a default Illum-size detection in a worker thread "
          "(twice), the light field loaded from a .npy:")
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "illum.npy")
        np.save(path, layered_light_field(ILLUM_SHAPE))
        for name, env in (("glibc defaults", {}),
                          ("Dask nanny, MALLOC_TRIM_THRESHOLD_=65536",
                           {"MALLOC_TRIM_THRESHOLD_": "65536"})):
            out = subprocess.run([sys.executable, "-c", _FRESH, path], capture_output=True,
                                 text=True, check=True, env=dict(os.environ, **env))
            r = json.loads(out.stdout.strip().splitlines()[-1])
            print(f"  {name}: peak memory the first call adds to the process "
                  f"{r['peak_added_mb']:.0f} MB; page faults first {r['first']}, second "
                  f"{r['second']} ({100 * r['second'] / max(r['first'], 1):.2f}% of the first)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    rounds = 3 if args.quick else args.rounds
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, cv2 {cv2.__version__}, liff core on OpenCV "
          f"{liff.opencvVersion()}; load average before: {os.getloadavg()[0]:.2f}")
    sift = cv2.SIFT.create()
    for name, lf in scenes(args.quick).items():
        view = centre_view(lf)
        has_first_octave = any(p.name == "firstOctave" for p in liff.PARAMETERS)
        default = liff.LiFF.create()
        first0 = liff.LiFF.create(firstOctave=0) if has_first_octave else default
        print(f"\n## {name}")
        liff.setNumThreads(1)
        cv2.setNumThreads(1)
        default.detectAndCompute(lf, None)  # warm
        t = interleaved(rounds, liff=lambda: default.detectAndCompute(lf, None),
                        liff0=lambda: first0.detectAndCompute(lf, None),
                        sift=lambda: sift.detectAndCompute(view, None))
        kps = len(default.detectAndCompute(lf, None)[0])
        print(f"one thread, {rounds} rounds (median seconds): LiFF {statistics.median(t['liff']):.3f} "
              f"({kps} features, {len(default.getSearchedSlopes())} slopes searched), "
              f"LiFF firstOctave=0 {statistics.median(t['liff0']):.3f}, "
              f"cv2.SIFT centre view {statistics.median(t['sift']):.3f}")
        print(f"LiFF / cv2.SIFT = {median_ratio(t['liff'], t['sift']):.2f}; with firstOctave=0: "
              f"{median_ratio(t['liff0'], t['sift']):.2f}")
        survey_cost(default, lf, rounds)

        def threads(n):
            def run():
                liff.setNumThreads(n)
                default.detectAndCompute(lf, None)
            return run

        t2 = interleaved(rounds, one=threads(1), two=threads(2))
        print(f"two threads against one: {median_ratio(t2['one'], t2['two']):.2f}x "
              f"(medians {statistics.median(t2['one']):.3f} and {statistics.median(t2['two']):.3f} s)")
        if hasattr(core, "_hooks"):
            stage_model(default, lf)
        else:  # a core from before the loop profiler: its stages only, hooks by their old names
            liff.setNumThreads(1)
            core._set_profiling(True)
            core._reset_profile()
            wall = seconds(lambda: default.detectAndCompute(lf, None))
            stages = core._stage_seconds()
            core._set_profiling(False)
            print(f"\none thread, profiled: wall {wall:.3f} s; " + ", ".join(
                f"{name} {s:.3f} s" for name, s in stages.items()))
        liff.setNumThreads(1)
        views = [centre_view(lf[i:i + 1, j:j + 1]) for i in range(lf.shape[0])
                 for j in range(lf.shape[1])]
        repeated = seconds(lambda: [sift.detectAndCompute(v, None) for v in views])
        once = min(seconds(lambda: default.detectAndCompute(lf, None)) for _ in range(2))
        print(f"\nrepeated SIFT on all {len(views)} views {repeated:.2f} s / LiFF {once:.3f} s "
              f"= {repeated / once:.0f}x (one thread)")
    if not args.quick:
        fresh_process_memory()
    return 0


if __name__ == "__main__":
    sys.exit(main())
