"""Process pools that stop when told to (used by liff's --workers runs)."""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor


def stop_now(pool: ProcessPoolExecutor) -> None:
    """Cancels ``pool``'s queued tasks and ends its worker processes at once (on Ctrl-C,
    SIGTERM or a worker's error): ``shutdown(wait=False)`` alone lets the running tasks,
    and with them the caller, go on to the end."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()
