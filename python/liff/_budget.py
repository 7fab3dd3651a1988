"""The memory budget: how many bytes a light field liff reads, and the detection that
follows, may take.

One mechanism serves the readers (``liff.io``) and the detector (``liff.cli.common.
make_detector``): when :data:`memory_budget_bytes` is set (``liff.batch`` sets it on a
Dask worker from the worker's memory limit), the room is that budget less what the
process holds now (:func:`held_bytes`); otherwise it is the memory available now, as
LiFF's core counts it for its default limit (``MemAvailable`` from ``/proc/meminfo``,
capped by the room under the cgroup's limit; ``cpp/src/memory.cpp``).

Readers call :func:`check_fits` with the size a file's header states *before* they
allocate or inflate anything, so that a small file claiming a huge light field is a
``MemoryError`` naming the file, the size claimed and the budget, never an allocation
that takes the machine down.
"""

from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

#: Bytes this process may hold while a detector made here runs, its input included
#: (None: no set budget; the room is the memory available when a call starts).
#: liff.batch sets it on a Dask worker from the worker's memory limit.
memory_budget_bytes: Optional[int] = None


def held_bytes() -> int:
    """Memory this process holds that a detection cannot use: its resident size less
    the working memory LiFF keeps for reuse (``liff.keptWorkingMemoryBytes``, which the
    next call takes rather than adds to), at least 0."""
    import psutil  # a dependency of distributed: this runs on Dask workers

    from ._core import keptWorkingMemoryBytes

    return max(0, psutil.Process().memory_info().rss - keptWorkingMemoryBytes())


def _first_number(path: str) -> Optional[float]:
    """The first word of a file as a number; None if absent, unreadable or "max"."""
    try:
        with open(path) as f:
            word = f.read(64).split()[0]
        return float(word)
    except (OSError, IndexError, ValueError):
        return None


def _stat_value(path: str, key: str) -> float:
    """The value of ``key`` in a cgroup memory.stat file, or 0."""
    try:
        with open(path) as f:
            for line in f:
                name, _, value = line.partition(" ")
                if name == key:
                    return float(value)
    except (OSError, ValueError):
        pass
    return 0.0


def _cgroup_room() -> Optional[float]:
    """Room left under this process's cgroup memory limit (v2, then v1), or None."""
    for limit_file, usage_file, stat_file, inactive, no_limit in (
            ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current",
             "/sys/fs/cgroup/memory.stat", "inactive_file", math.inf),
            ("/sys/fs/cgroup/memory/memory.limit_in_bytes",
             "/sys/fs/cgroup/memory/memory.usage_in_bytes",
             "/sys/fs/cgroup/memory/memory.stat", "total_inactive_file", 1e18)):
        limit = _first_number(limit_file)
        if limit is not None and 0 < limit < no_limit:
            used = (_first_number(usage_file) or 0.0) - _stat_value(stat_file, inactive)
            return max(1.0, limit - max(0.0, used))
    return None


def available_bytes() -> Optional[int]:
    """The memory available now, as LiFF's core counts it: ``MemAvailable`` capped by the
    cgroup's room; None where neither can be read (no bound)."""
    available = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    available = float(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    room = _cgroup_room()
    if room is not None:
        available = room if available is None else min(available, room)
    return None if available is None else int(available)


def room_bytes() -> Tuple[Optional[int], str]:
    """(bytes a light field may take now, where that figure comes from); (None, ...)
    when there is no bound."""
    if memory_budget_bytes is not None:
        held = held_bytes()
        return (max(0, memory_budget_bytes - held),
                f"the memory budget of {memory_budget_bytes / 1e6:,.0f} MB less the "
                f"{held / 1e6:,.0f} MB the process holds")
    available = available_bytes()
    return available, "the memory available now (MemAvailable, capped by the cgroup limit)"


def array_bytes(shape: Sequence[int], itemsize: int) -> int:
    """Bytes of an array of ``shape`` with items of ``itemsize`` bytes (Python ints: no
    overflow whatever a header claims)."""
    total = int(itemsize)
    for length in shape:
        total *= max(0, int(length))
    return total


def check_fits(source: str, claimed: int, what: str) -> None:
    """Raises MemoryError naming ``source``, ``what`` and the ``claimed`` bytes when they
    exceed the room the memory budget leaves (:func:`room_bytes`).

    Parameters
    ----------
    source : str
        The file (or file and key) whose header states the size.
    claimed : int
        Bytes the header says reading it will allocate.
    what : str
        What takes them, e.g. "a light field of shape (9, 9, 512, 512, 3) uint8".

    Raises
    ------
    MemoryError
        ``"SOURCE: WHAT takes N MB; expected at most the M MB of FROM"``.
    """
    room, origin = room_bytes()
    if room is not None and claimed > room:
        raise over_budget(source, claimed, what, room, origin)


def over_budget(source: str, claimed: int, what: str, room: int, origin: str) -> MemoryError:
    """The MemoryError for ``what`` in ``source`` taking ``claimed`` bytes where the
    budget leaves ``room`` (from :func:`room_bytes`, which says its ``origin``)."""
    return MemoryError(f"{source}: {what} takes {claimed / 1e6:,.0f} MB; expected at most "
                       f"the {room / 1e6:,.0f} MB of {origin}")
