"""Local process pools: a batch's jobs on ``--workers`` processes (or here), with
progress on stderr and each failure reported as the command line reports it
(:func:`run_batch`), and pools that stop when told to (:func:`stop_now`).

Layer: the batch runs' (tests/test_layers.py).
"""

from __future__ import annotations

import os
import signal
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from functools import partial
from typing import Any, Callable, List, Optional, Sequence, Tuple

from ._core import setNumThreads
from ._flags import error_line
from ._progress import progress


def stop_now(pool: ProcessPoolExecutor) -> None:
    """Cancels ``pool``'s queued tasks and ends its worker processes at once (on Ctrl-C,
    SIGTERM or a worker's error): ``shutdown(wait=False)`` alone lets the running tasks,
    and with them the caller, go on to the end."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()


def run_batch(function: Callable, jobs: Sequence[tuple], workers: int, command: str,
              label: Callable[[tuple], str],
              done: Optional[Callable[[Any], None]] = None,
              failed: Callable[[Any], bool] = lambda result: False) -> Tuple[List, int]:
    """Runs ``function(*job)`` for every job, on ``workers`` processes (1 = here), with a
    progress bar on stderr (see :func:`progress`). A job that raises is reported as
    ``liff <command>: <label>: <error>`` and the rest go on; ``done(result)`` is called
    with each job's result as it comes (e.g. to write a manifest as the run goes).
    The progress names each job that finished (``label``), and counts those that raised
    or ``failed(result)`` apart from those done.

    Returns (results in job order, None for failures; number of failures).
    """
    results: List = [None] * len(jobs)
    failures = 0
    progress = _progress(len(jobs), command)

    def report(i: int, error: BaseException) -> None:
        nonlocal failures
        failures += 1
        message = error_line(command, label(jobs[i]), str(error))
        (progress.write(message, file=sys.stderr) if progress else print(message, file=sys.stderr))

    def settle(i: int, result: Callable[[], object]) -> None:
        """Job i's result (``result()``, which raises the job's error), counted."""
        try:
            results[i] = result()
            if done:
                done(results[i])
            finished(progress, label(jobs[i]), failed=failed(results[i]))
        except (ValueError, OSError, MemoryError) as error:
            report(i, error)
            finished(progress, label(jobs[i]), failed=True)

    try:
        if workers <= 1 or len(jobs) <= 1:
            for i, job in enumerate(jobs):
                settle(i, partial(function, *job))
        else:
            # Each worker gets its share of the cores: LiFF uses all of them by default, and
            # N processes that each did would oversubscribe the machine N times over.
            threads = max(1, (os.cpu_count() or 1) // workers)
            pool = ProcessPoolExecutor(max_workers=workers, initializer=_set_threads,
                                       initargs=(threads,))
            try:
                futures = {pool.submit(function, *job): i for i, job in enumerate(jobs)}
                for future in as_completed(futures):
                    settle(futures[future], future.result)
            except BaseException:  # Ctrl-C, SIGTERM: stop now, not after the queued jobs
                stop_now(pool)
                raise
            pool.shutdown()
    finally:  # however the run ends: a bar left open says "still working" forever
        if progress:
            progress.close()
    return results, failures


def finished(bar, item: str, failed: bool = False) -> None:
    """Counts the input ``item`` finished on the progress ``bar`` (None: no bar): done,
    named as tqdm's postfix and the log line's ``last ITEM``; or ``failed``, counted
    apart from those done (``K failed``), not named again (its error line names it)."""
    if bar is None:
        return
    if failed and hasattr(bar, "fail"):  # (LineProgress)
        bar.fail()
        return
    if failed:
        bar.liff_failed = getattr(bar, "liff_failed", 0) + 1
        bar.set_postfix_str(f"{bar.liff_failed} failed", refresh=False)
    else:
        bar.set_postfix_str(item or "", refresh=False)
    bar.update()


def _set_threads(threads: int) -> None:
    """Worker initializer: LiFF's thread count for this process, and SIGTERM's default
    action (a forked worker inherits the CLI's handler, which would let it finish its
    light field before the pool could end it)."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)

    setNumThreads(threads)


def _progress(total: int, command: str):
    """A bar for the jobs of a batch (even one: a large light field takes seconds)."""
    return progress(desc=f"liff {command}", total=total) if total else None
