"""What a command says on stderr while the user waits: a tqdm bar on a terminal, plain
lines in a log (stderr not a terminal: nohup, CI, a job scheduler), nothing with
``--quiet``. (Below the batch runs, whose local pool shows it too; the command line
reaches it as ``liff.cli.progress`` and sets :data:`QUIET`.)

In a log, a batch prints a line per finished input (other units, such as pairs or poses,
at most one every :data:`LINE_SECONDS`, and the last), and anything that runs long
without finishing an item (one large light field, a mapping step) prints a line every
:data:`HEARTBEAT_SECONDS`. ``LIFF_PROGRESS`` set in the environment forces the bar.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from contextlib import contextmanager
from typing import Iterable, Optional, Sized

QUIET = False
"""Set by the commands' ``--quiet``: no bars, progress or step lines (errors still shown)."""

LINE_SECONDS = 10.0
"""In a log, the shortest time between two progress lines of units other than files."""

HEARTBEAT_SECONDS = 30.0
"""In a log, a line at least this often while a step or an item is still running."""

HEARTBEAT_THREAD = "liff progress heartbeat"
"""The name of the threads that say so (one per open progress line or step)."""


def _bar_wanted() -> bool:
    return "LIFF_PROGRESS" in os.environ or sys.stderr.isatty()


class _Heartbeat:
    """Calls ``say()`` every :data:`HEARTBEAT_SECONDS` of silence (``last`` is when
    something was last said) from a daemon thread, until closed."""

    def __init__(self, say):
        self._say = say
        self.lock = threading.Lock()
        self.last = time.monotonic()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name=HEARTBEAT_THREAD)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(min(1.0, HEARTBEAT_SECONDS / 4)):
            with self.lock:
                if time.monotonic() - self.last >= HEARTBEAT_SECONDS:
                    self._say()
                    self.last = time.monotonic()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)


class LineProgress:
    """tqdm's interface as we use it (iteration, ``update``, ``set_postfix_str``,
    ``write``, a context manager), printed as lines for a log: ``DESC: N/TOTAL UNIT(s)
    done, last ITEM, S s``, ITEM the postfix set (the input that finished); inputs that
    failed (:meth:`fail`) are not counted done but said apart: ``..., K failed, S s``
    (their error lines name them)."""

    def __init__(self, iterable: Optional[Iterable] = None, desc: str = "liff",
                 total: Optional[int] = None, unit: str = "file"):
        self.iterable = iterable
        if total is None and isinstance(iterable, Sized):
            total = len(iterable)
        self.desc, self.total, self.unit, self.n = desc, total, unit, 0
        self.item: Optional[str] = None
        self.failed = 0
        self.start = time.monotonic()
        self._heartbeat = _Heartbeat(lambda: self._line(", still working"))

    def _line(self, note: str = "") -> None:
        total = f"/{self.total}" if self.total is not None else ""
        last = f", last {self.item}" if self.item else ""
        failed = f", {self.failed} failed" if self.failed else ""
        print(f"{self.desc}: {self.n - self.failed}{total} {self.unit}(s) done{last}{failed}, "
              f"{time.monotonic() - self.start:.0f} s{note}", file=sys.stderr, flush=True)

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        """What finished last (tqdm's postfix): named in the next line."""
        with self._heartbeat.lock:
            self.item = s or None

    def update(self, n: int = 1) -> None:
        with self._heartbeat.lock:
            self.n += n
            now = time.monotonic()
            if (self.unit == "file" or self.n == self.total
                    or now - self._heartbeat.last >= LINE_SECONDS):
                self._line()
                self._heartbeat.last = now

    def fail(self) -> None:
        """One input finished by failing: counted apart from those done (its error line
        names it; the progress line does not name it again)."""
        with self._heartbeat.lock:
            self.failed += 1
            self.item = None
        self.update()

    def write(self, text: str, file=None) -> None:
        with self._heartbeat.lock:
            print(text, file=file or sys.stderr, flush=True)

    def close(self) -> None:
        self._heartbeat.close()

    def __iter__(self):
        try:
            for item in self.iterable:
                yield item
                self.update()
        finally:
            self.close()

    def __enter__(self) -> "LineProgress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def progress(iterable: Optional[Iterable] = None, desc: str = "liff",
             total: Optional[int] = None, unit: str = "file"):
    """Progress on stderr: a tqdm bar on a terminal (or with ``LIFF_PROGRESS`` set),
    :class:`LineProgress` lines in a log, a silent bar with ``--quiet``."""
    from tqdm import tqdm  # lazy: tqdm only once a bar is shown

    if QUIET or _bar_wanted():
        return tqdm(iterable, desc=desc, total=total, unit=unit, file=sys.stderr,
                    disable=QUIET)
    return LineProgress(iterable, desc, total, unit)


@contextmanager
def step(text: str):
    """Says on stderr that a step without a progress bar starts and how long it took;
    in a log, also a line every :data:`HEARTBEAT_SECONDS` while it runs. Nothing with
    ``--quiet``."""
    if QUIET:
        yield
        return
    print(f"{text} ...", file=sys.stderr, flush=True)
    start = time.monotonic()
    heartbeat = None if _bar_wanted() else _Heartbeat(
        lambda: print(f"{text}: still running, {time.monotonic() - start:.0f} s",
                      file=sys.stderr, flush=True))
    try:
        yield
    finally:
        if heartbeat:
            heartbeat.close()
    print(f"{text}: done in {time.monotonic() - start:.1f} s", file=sys.stderr, flush=True)
