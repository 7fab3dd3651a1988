"""The memory budget: how many bytes a light field liff reads, and the detection that
follows, may take.

One mechanism serves the readers (``liff.io``) and the detector (``liff._detection.
make_detector``): when :data:`memory_budget_bytes` is set (``liff.batch`` sets it on a
Dask worker from the worker's memory limit), the room is that budget less what the
process holds now (:func:`held_bytes`); otherwise it is the memory available now, as
LiFF's core counts it for its default limit (``liff._core.availableMemoryBytes``:
``MemAvailable`` capped by the room under the cgroup's limit; ``cpp/src/memory.cpp``).

Readers call :func:`check_fits` with the size a file's header states *before* they
allocate or inflate anything, so that a small file claiming a huge light field is a
``MemoryError`` naming the file, the size claimed and the budget, never an allocation
that takes the machine down.
"""

from __future__ import annotations

from typing import Optional, Sequence, Tuple

from . import _core

#: Bytes this process may hold while a detector made here runs, its input included
#: (None: no set budget; the room is the memory available when a call starts).
#: liff.batch sets it on a Dask worker from the worker's memory limit.
memory_budget_bytes: Optional[int] = None


def held_bytes() -> int:
    """Memory this process holds that a detection cannot use: its resident size less
    the working memory LiFF keeps for reuse (``liff.keptWorkingMemoryBytes``, which the
    next call takes rather than adds to), at least 0."""
    import psutil  # a dependency of distributed: this runs on Dask workers

    return max(0, psutil.Process().memory_info().rss - _core.keptWorkingMemoryBytes())


def available_bytes() -> Optional[int]:
    """The memory available now, as LiFF's core counts it for its default limit
    (``liff._core.availableMemoryBytes``: MemAvailable capped by the cgroup's room, plus
    the working memory the core keeps); None where it cannot be read (no bound)."""
    available = _core.availableMemoryBytes()
    return int(available) if available > 0 else None


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
