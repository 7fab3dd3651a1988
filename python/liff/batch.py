"""Dataset-scale detection: one task per light field, on a Dask cluster or local processes.

``liff detect PATHS --out DIR --scheduler ADDRESS`` and :func:`detect` run each light
field as a task on a Dask distributed cluster (``pip install 'liff[dask]'``; start it
with Dask's own ``dask scheduler`` and ``dask worker ADDRESS``). What survives what:

- a worker that dies mid-run: Dask runs its tasks on the other workers;
- a light field that fails (damaged file, wrong format, too large): its
  :class:`Outcome` carries the error, the rest go on;
- a run killed at any moment: every output is written to a temporary name and renamed
  when complete (:mod:`liff.outputs`), so none is truncated; a re-run redoes only what
  is missing or was made with other settings (:func:`liff._tasks.changes`);
- an unreachable scheduler: :class:`ValueError` within ``timeout`` seconds.

On a worker a task takes the worker's resources: LiFF runs one light field at a time
per worker process with the worker's thread count (``liff.setNumThreads``) and a memory
limit (``setMemoryLimitMB``): MEMORY_SHARE of the worker's, less what the process holds
once the light field is read (its input array included), so a light field too large for
the worker is refused (``MemoryError`` in its outcome) or processed in less memory, rather
than the worker being killed for exceeding its memory. The detector keeps its working
memory from one task to the next in the same process (``liff.keptWorkingMemoryBytes``).
"""

from __future__ import annotations

import argparse
import csv
import itertools
import os
import threading
import time
import warnings
from contextlib import ExitStack, contextmanager
from dataclasses import asdict, fields
from typing import TYPE_CHECKING, List, Optional, Sequence

from . import _budget
from ._core import getNumThreads, setNumThreads
from ._detection import SLOPE_BOUNDS, make_detector, with_defaults
from ._detector import PARAMETERS
from ._flags import name_flags
from ._inputs import protected_inputs
from ._paths import special_kind
from ._processes import run_batch
from ._tasks import Detected, Outcome, Task, detect_one, plan, read_as  # noqa: F401 (liff.batch.*)
from ._warnings import LiffWarning
from .outputs import atomic_output, make_folder, refuse_inputs

if TYPE_CHECKING:  # (an optional dependency: pip install "liff[dask]")
    import distributed

#: What each task may use of its worker's memory limit (Dask's nanny pauses a worker at
#: 80% and kills it at 95%), less what the process already holds.
MEMORY_SHARE = 0.75
#: Seconds to wait for a scheduler before saying it cannot be reached.
CONNECT_TIMEOUT = 10
#: Seconds between rewrites of a manifest at the most while a run goes (ManifestWriter).
MANIFEST_SECONDS = 1.0


_ONE_AT_A_TIME = threading.Lock()  # per worker process: LiFF already uses every thread


def run_task(task: Task) -> Outcome:
    """Runs one task where it is (a Dask worker, a local process, here) and returns its
    outcome; an error reading, detecting or writing is in ``Outcome.error``, not raised."""
    with _ONE_AT_A_TIME, _worker_resources() as worker:
        start, cpu = time.perf_counter(), time.process_time()
        try:
            result = detect_one(*task)
            outcome = Outcome(task.source, task.output, "done", result.features,
                              *result.slope_range, result.searched, result.built,
                              result.slopes_from,
                              notes="\n".join(map(name_flags, result.notes)),
                              **read_as(task.reader_options))
        except Exception as error:  # reported in the manifest, as every failure of a task
            outcome = Outcome(task.source, task.output, "failed",
                              error=f"{type(error).__name__}: {name_flags(str(error))}"
                                    f"{_memory_hint(error)}", **read_as(task.reader_options))
        outcome.seconds = round(time.perf_counter() - start, 3)
        outcome.cpu_seconds = round(time.process_time() - cpu, 3)
        outcome.worker = worker
    return outcome


def _memory_hint(error: Exception) -> str:
    """For a MemoryError on a Dask worker: where the limit came from (not only
    setMemoryLimitMB, which the user does not call here)."""
    if not isinstance(error, MemoryError) or _budget.memory_budget_bytes is None:
        return ""
    return (f" (on this Dask worker: {MEMORY_SHARE:.0%} of its memory limit, "
            f"{_budget.memory_budget_bytes / MEMORY_SHARE / 1e6:.0f} MB, less what the worker "
            "process holds with the light field read; or give workers more memory: dask worker "
            "--memory-limit)")


@contextmanager
def _worker_resources():
    """On a Dask worker, LiFF's threads and memory limit from the worker's for the
    duration of a task (then restored: an in-process worker shares them with its
    client); yields the worker's address, or '' elsewhere."""
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):  # not on a Dask worker
        yield ""
        return
    threads, budget = getNumThreads(), _budget.memory_budget_bytes
    setNumThreads(worker.state.nthreads)
    limit = worker.memory_manager.memory_limit
    if limit:
        # The detector's limit is what this leaves once the input is read (make_detector).
        _budget.memory_budget_bytes = int(MEMORY_SHARE * limit)
    try:
        yield worker.address
    finally:
        setNumThreads(threads)
        _budget.memory_budget_bytes = budget


def connect(client) -> "distributed.Client":
    """A ``distributed.Client``: ``client`` itself, or one connected to the scheduler at
    the address ``client``.

    Raises
    ------
    ImportError
        Without Dask (``pip install 'liff[dask]'``).
    ValueError
        If no scheduler answers at the address within :data:`CONNECT_TIMEOUT` seconds.
    """
    try:
        import distributed
    except ImportError:
        raise ImportError("a Dask cluster needs dask and distributed: pip install 'liff[dask]'") from None
    if isinstance(client, distributed.Client):
        return client
    expected = "expected the address of a running `dask scheduler`, e.g. tcp://10.0.0.5:8786"
    if isinstance(client, (str, os.PathLike)):
        _identify_scheduler(os.fspath(client), expected)
    try:
        return distributed.Client(client, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as error:
        raise ValueError(f"cannot reach a Dask scheduler at {client} within {CONNECT_TIMEOUT} s "
                         f"({error}); {expected}") from None


def _identify_scheduler(address: str, expected: str) -> dict:
    """The identity of the Dask scheduler at ``address`` (its "identity" message: type,
    workers), asked within :data:`CONNECT_TIMEOUT` seconds in all; ValueError if nothing
    answers or what answers is not a Dask scheduler. (``distributed.Client`` bounds only
    the TCP connection: a server that accepts it and never speaks Dask's handshake, such
    as a dashboard port, would hold it forever, and an HTTP reply read as a frame length
    asks for exabytes.)"""
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    from distributed.comm import connect as open_comm
    from distributed.comm import registry
    from distributed.comm.addressing import parse_address, parse_host_port

    try:  # what Dask would refuse before connecting: a scheme it lacks, no port
        scheme, location = parse_address(address)
        registry.get_backend(scheme)
        if scheme in ("tcp", "tls"):
            parse_host_port(location)
    except (ValueError, TypeError) as error:
        raise ValueError(f"{address!r} is not an address of a Dask scheduler ({error}); "
                         f"{expected}") from None

    from distributed.security import Security

    async def identify():  # (Dask's security settings, as a Client takes them: tls://)
        comm = await open_comm(address, timeout=CONNECT_TIMEOUT,
                               **Security().get_connection_args("client"))
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    async def within_deadline():
        return await asyncio.wait_for(identify(), CONNECT_TIMEOUT)

    # In a thread of its own: the caller may be running an event loop (Jupyter).
    with ThreadPoolExecutor(1) as thread:
        try:
            identity = thread.submit(asyncio.run, within_deadline()).result()
        except (OSError, TimeoutError, asyncio.TimeoutError) as error:
            raise ValueError(f"cannot reach a Dask scheduler at {address} within "
                             f"{CONNECT_TIMEOUT} s ({str(error) or 'no answer in the time'}); "
                             f"{expected}") from None
        except Exception as error:  # e.g. MemoryError: an HTTP reply read as a frame length
            raise ValueError(f"{address} answered, but not as a Dask scheduler ("
                             f"{type(error).__name__} reading its reply); {expected}") from None
    if not isinstance(identity, dict) or "Scheduler" not in str(identity.get("type")):
        raise ValueError(f"{address} answered, but not as a Dask scheduler; {expected}")
    return identity


def run(tasks: Sequence[Task], client, progress=None, notice=None,
        worker_profiler: bool = False) -> List[Outcome]:
    """Runs every task on the Dask cluster of ``client`` (a ``distributed.Client`` or a
    scheduler's address) and returns their outcomes in task order.

    ``progress``: a callable told each outcome as it arrives (e.g. a progress bar's).
    ``notice``: a callable told a line of text when the scheduler has no worker yet (the
    tasks wait for workers to join); by default a :class:`liff.LiffWarning`.
    ``worker_profiler``: leave the workers' statistical profiler running. By default it
    is paused for the run and restarted after (:mod:`liff._dask_workers`: it cannot see
    into LiFF's C++, and it about doubles Dask's own processor time in a worker, 43-48
    against 23 ms per Illum-size task in benchmarks/batch.py)."""
    own = not _is_client(client)  # made here from an address: closed here
    client = connect(client)
    try:
        with ExitStack() as paused:
            if tasks and not worker_profiler:
                paused.enter_context(_profiler_paused(client))
            return _run_on(client, tasks, progress, notice)
    finally:
        if own:
            client.close()


@contextmanager
def _profiler_paused(client):
    """The workers' profiler paused (a worker plugin, so workers that join get it too)
    until the block ends."""
    from ._dask_workers import PausedProfiler  # lazy: defers distributed (optional: liff[dask])

    # (register_plugin since distributed 2023.9.2; register_worker_plugin before it)
    register = getattr(client, "register_plugin", None) or client.register_worker_plugin
    try:  # (registering inside: an interrupt meanwhile still unregisters)
        register(PausedProfiler(), name=PausedProfiler.name)
        yield
    finally:
        try:
            client.unregister_worker_plugin(PausedProfiler.name)
        except Exception:  # the cluster went away meanwhile: nothing left to restore
            pass


def _run_on(client, tasks: Sequence[Task], progress, notice) -> List[Outcome]:
    """Says when no worker has joined yet, then gathers the tasks' outcomes."""
    if tasks and not client.nthreads():
        text = (f"no Dask worker has joined the scheduler at {client.scheduler.address} "
                "yet; the tasks wait for one (start workers with `dask worker "
                f"{client.scheduler.address}`)")
        if notice:
            notice(text)
        else:
            warnings.warn(text, LiffWarning, stacklevel=3)  # (the caller of run)
    return _gather(client, tasks, progress)


def _is_client(client) -> bool:
    try:
        from distributed import Client
    except ImportError:
        return False
    return isinstance(client, Client)


def _gather(client, tasks: Sequence[Task], progress) -> List[Outcome]:
    """Submits every task and collects the outcomes, in task order, as they complete."""
    from distributed import as_completed

    futures = client.map(run_task, list(tasks), pure=False)
    index = {future.key: i for i, future in enumerate(futures)}
    outcomes: List[Optional[Outcome]] = [None] * len(futures)
    for future in as_completed(futures):
        i = index[future.key]
        try:
            outcomes[i] = future.result()
        except Exception as error:  # e.g. KilledWorker: the task killed every worker it met
            outcomes[i] = Outcome(tasks[i].source, tasks[i].output, "failed",
                                  error=f"{type(error).__name__}: {error}",
                                  **read_as(tasks[i].reader_options))
        if progress:
            progress(outcomes[i])
    return [outcome for outcome in outcomes if outcome is not None]  # (every one set above)


#: A manifest's columns: the Outcome fields, in order.
MANIFEST_FIELDS = tuple(field.name for field in fields(Outcome))


def write_manifest(path: str, outcomes: Sequence[Outcome]) -> None:
    """Writes the outcomes as CSV (one row per light field, a header of the
    :class:`Outcome` fields), which pandas (``pd.read_csv``) and spreadsheets read."""
    with atomic_output(path) as partial, open(partial, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=MANIFEST_FIELDS)
        writer.writeheader()
        writer.writerows(asdict(outcome) for outcome in outcomes)


class ManifestWriter:
    """A run's manifest written as the run goes: each outcome :meth:`add`-ed is in the
    file within ``every`` seconds, and leaving the ``with`` block (the run done,
    failed, interrupted by Ctrl-C or SIGTERM) writes every outcome so far. Each write
    replaces the file atomically (:func:`write_manifest`), so a run stopped at any
    moment (SIGKILL, a full disk) leaves the manifest of what it had finished by its
    last write, never a truncated one.

    Parameters
    ----------
    path : str
        The manifest.
    outcomes : sequence of Outcome
        Rows known before the run (outputs kept), written at once.
    every : float, optional
        Seconds between writes at the most while outcomes come (default
        :data:`MANIFEST_SECONDS`; the whole manifest is rewritten each time, so a run
        of many short tasks does not rewrite it per task).
    """

    def __init__(self, path: str, outcomes: Sequence[Outcome] = (),
                 every: Optional[float] = None):
        every = MANIFEST_SECONDS if every is None else every
        self.path, self.every, self.outcomes = path, every, list(outcomes)
        self.written = time.monotonic()
        write_manifest(path, self.outcomes)

    def add(self, outcome: Outcome) -> None:
        self.outcomes.append(outcome)
        if time.monotonic() - self.written >= self.every:
            self.write()

    def write(self) -> None:
        write_manifest(self.path, self.outcomes)
        self.written = time.monotonic()

    def __enter__(self) -> "ManifestWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.write()


def new_manifest_name(folder: str, now: Optional[float] = None) -> str:
    """``FOLDER/manifest-<UTC time>.csv``, created empty at once so that no other run
    takes the name: a run started in the same second gets ``...-2.csv`` (then -3, ...).
    ``now``: the time (``time.time()``, the default).

    Raises
    ------
    ValueError
        Naming the folder, if the file cannot be created there.
    """
    make_folder(folder)
    stamp = time.strftime("manifest-%Y%m%d-%H%M%S", time.gmtime(now))
    for number in itertools.count(1):
        path = os.path.join(folder, stamp + (f"-{number}" if number > 1 else "") + ".csv")
        try:
            os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
            return path
        except FileExistsError:
            continue
        except OSError as error:
            raise ValueError(f"{folder}: cannot create a manifest there ({error.strerror}); "
                             "expected a writable --out folder") from None
    raise AssertionError("unreachable")


def is_manifest(path: str) -> bool:
    """Whether ``path`` is a manifest :func:`write_manifest` wrote (its CSV header)."""
    header = ",".join(MANIFEST_FIELDS)
    if special_kind(path) is not None:  # a FIFO would block
        return False
    try:
        with open(path, newline="") as f:
            return f.readline().rstrip("\r\n") == header
    except (OSError, UnicodeDecodeError):
        return False


@contextmanager
def manifest_writer(manifest: Optional[str], kept: List[Outcome]):
    """A :class:`ManifestWriter` for ``manifest`` starting with the ``kept``
    outcomes, or None without a manifest."""
    if not manifest:
        yield None
        return
    with ManifestWriter(manifest, kept) as writer:
        yield writer


def check_manifest(manifest: str, args: argparse.Namespace, tasks: List[Task],
                   kept: List[Outcome]) -> None:
    """Raises ValueError, before anything runs, if the manifest would write over an
    input, over another output of the run, or over an existing file that is not a liff
    manifest (unless ``--overwrite``)."""
    refuse_inputs([manifest], protected_inputs(args), "--manifest")  # (and a FIFO)
    outputs = [t.output for t in tasks] + [t.plot for t in tasks if t.plot] + [k.output for k in kept]
    if any(os.path.exists(o) and os.path.exists(manifest) and os.path.samefile(o, manifest) or
           os.path.abspath(o) == os.path.abspath(manifest) for o in outputs):
        raise ValueError(f"{manifest}: is also an output of this run; expected a --manifest "
                         "path of its own; nothing was written")
    if os.path.exists(manifest) and not args.overwrite and not is_manifest(manifest):
        raise ValueError(f"{manifest}: exists and is not a liff manifest; expected a new "
                         "--manifest path (or --overwrite to replace it); nothing was written")


def detect(paths: Sequence[str], out: str, client=None, workers: int = 1,
           reader_options: Optional[dict] = None, preprocess: bool = False,
           overwrite: bool = False, manifest: Optional[str] = None, **parameters) -> List[Outcome]:
    """LiFF features of many light fields, one ``.npz`` each in the folder ``out``.

    Parameters
    ----------
    paths : str or sequence of str
        Light fields, folders of light fields, glob patterns (see
        :func:`liff._inputs.expand_inputs`); nothing is written inside a folder
        given.
    out : str
        Output folder (created if missing).
    client : distributed.Client or str, optional
        A Dask client or a scheduler's address; without it, ``workers`` local processes.
    reader_options, preprocess
        As :func:`liff.io.read_light_field` takes them, and the paper's preprocessing.
    overwrite : bool
        Redo outputs made with the same settings too.
    manifest : str, optional
        Where to write the run's manifest (CSV), as the run goes (:class:`ManifestWriter`:
        a run stopped early leaves the manifest of what it finished); refused
        (ValueError, before anything runs) if it is an input, an output, or an existing
        file other than a liff manifest (unless ``overwrite``).
    **parameters
        ``liff.LiFF.create`` keywords. A slope bound not given comes from the range a
        reader knows (an HCI scene's parameters.cfg), else is automatic, as in
        ``liff detect``.

    Returns
    -------
    list of Outcome
        One per light field: done, failed (with the error) or kept.

    Raises
    ------
    ValueError
        Before anything runs: bad parameters or ``workers``, outputs over inputs or
        inside a folder given, a manifest over an input, an output or a foreign file.
    """
    if isinstance(paths, (str, os.PathLike)):  # one path, not its letters
        paths = [paths]
    if not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers = {workers!r}; expected a whole number >= 1")
    args = argparse.Namespace(paths=list(paths), out=os.path.join(out, ""), plot=None,
                              overwrite=overwrite, preprocess=preprocess, from_list=None)
    # slope bounds not given: a reader's range if it knows one, else automatic
    wanted = {p.name: parameters.pop(p.name, None if p.name in SLOPE_BOUNDS else p.default)
              for p in PARAMETERS}
    if parameters:
        raise TypeError(f"unknown parameter(s) {sorted(parameters)}; expected liff.LiFF.create "
                        "keywords")
    make_detector(with_defaults(wanted))  # bad parameters: refused up front
    tasks, kept, _ = plan(args, dict(reader_options or {}), wanted)
    if manifest:
        check_manifest(manifest, args, tasks, kept)
    with manifest_writer(manifest, kept) as writer:
        done = writer.add if writer else None
        if client is not None:
            outcomes = run(tasks, client, progress=done)
        else:
            outcomes = run_batch(run_task, [(t,) for t in tasks], workers, "detect", str,
                                        done=done)[0]
        outcomes += kept
        if writer:
            writer.outcomes = outcomes  # in the order of the inputs
    return outcomes
