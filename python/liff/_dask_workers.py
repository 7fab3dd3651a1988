"""What a liff run changes on the Dask workers it uses, and puts back after
(:func:`liff.batch.run`).

Dask's workers sample the stacks of their task threads every 10 ms
(``distributed.worker.profile``) for the dashboard's profile page. A liff task is one
call into C++, which those samples cannot see into, and on a busy worker the sampling
runs on the worker's event loop, competing with the task for the cores: Dask's own CPU
in a worker was 43-48 ms per Illum-size task with it and 23 ms without, against LiFF's
0.73-0.81 s (benchmarks/batch.py; docs/BENCHMARKS.md). So for the run it is paused. (On
Python versions other than 3.11, distributed also samples its event loop's own thread
from a thread of its own; that sampler is left running.)
"""

from __future__ import annotations

from distributed.diagnostics.plugin import WorkerPlugin

#: The worker's periodic callbacks that drive its statistical profiler
#: (distributed's worker.py: ``periodic_callbacks["profile"]`` samples, ``"profile-cycle"``
#: files the samples away).
PROFILER_CALLBACKS = ("profile", "profile-cycle")


class PausedProfiler(WorkerPlugin):
    """A worker plugin: the worker's statistical profiler stops while the plugin is
    registered (from setup to teardown); workers that join meanwhile get it too.
    The callbacks are taken out of the worker's table, so a worker still starting does
    not start them, and put back (and started) at teardown."""

    name = "liff-paused-profiler"

    def setup(self, worker) -> None:
        self._paused = {}
        for key in PROFILER_CALLBACKS:
            callback = worker.periodic_callbacks.pop(key, None)
            if callback is not None:
                callback.stop()
                self._paused[key] = callback

    def teardown(self, worker) -> None:
        for key, callback in getattr(self, "_paused", {}).items():
            worker.periodic_callbacks[key] = callback
            if worker.status.name in ("running", "paused"):
                callback.start()
        self._paused = {}
