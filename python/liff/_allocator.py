"""The C allocator of a process that runs detection tasks one after another (glibc).

LiFF allocates a light field's buffers (the grey light field, focal slices, scale
spaces) anew in every call. glibc returns freed memory to the system once more than
M_TRIM_THRESHOLD of it sits at the top of the heap, and maps every allocation over
M_MMAP_THRESHOLD from the system; either way the next call gets fresh pages, which the
kernel faults in and zeroes one by one. On an Illum-size light field (11 x 11 views of
376 x 541) that was 63,000 page faults and 17-20% of a one-thread detection's processor
time, system time that a process keeping its freed memory does not spend
(benchmarks/batch.py measures tasks; docs/BENCHMARKS.md, "Batches and Dask").
Dask's nanny makes it worse: it starts workers with ``MALLOC_TRIM_THRESHOLD_=65536``,
which also turns off glibc's adaptive mmap threshold. And a Dask task runs in a worker
thread, whose allocations come from a thread arena: heaps of at most 64 MiB that glibc
unmaps as soon as one is wholly free, whatever M_TRIM_THRESHOLD says, unless M_TOP_PAD
asks it to keep that much (glibc's malloc/arena.c, heap_trim). With TOP_PAD_BYTES a
task in a thread reuses the heaps of the one before it as the main thread does; and
LiFF is told to allocate a converted light field view by view, not as one buffer,
which in a thread arena is larger than a heap and mapped anew on every call
(``setViewByViewAllocation`` in the core's light_field.hpp).

So a task's process keeps freed memory for the next task, up to a bound: RETAIN_SHARE
of the memory it may use (a Dask worker's limit, else the machine's) and at most
RETAIN_MAX_BYTES. A thread arena with TOP_PAD_BYTES never gives a heap back, so after
each task :func:`release_excess` returns all free memory when more than that is kept.
Memory so kept is reused by the next task, not added to it, and :func:`held_bytes`
leaves it out of what the process holds. Nothing happens where the
C library is not glibc.
"""

from __future__ import annotations

import ctypes
import os
from typing import Optional

import numpy as np

#: Allocations at least this large are mapped from the system and unmapped when freed
#: (glibc's M_MMAP_THRESHOLD; 32 MiB is the largest value glibc accepts).
MMAP_THRESHOLD_BYTES = 32 * 2**20
#: Size and alignment of a thread arena's heaps (glibc's HEAP_MAX_SIZE on 64-bit systems).
THREAD_HEAP_BYTES = 64 * 2**20
#: Free memory an arena keeps (glibc's M_TOP_PAD): a whole thread heap, so that a heap
#: that falls free is kept. It reserves address space; pages are faulted in when used,
#: so free memory not yet used is not resident (:func:`free_heap_bytes`).
TOP_PAD_BYTES = THREAD_HEAP_BYTES
#: Freed memory a process keeps for its next task (glibc's M_TRIM_THRESHOLD): this share
#: of the memory it may use...
RETAIN_SHARE = 0.25
#: ...and at most this much.
RETAIN_MAX_BYTES = 2**30

_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3  # <malloc.h>


class _MallInfo2(ctypes.Structure):
    """glibc's struct mallinfo2 (glibc 2.33 and later)."""

    _fields_ = [(name, ctypes.c_size_t) for name in (
        "arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks",
        "fordblks", "keepcost")]


def _glibc() -> Optional[ctypes.CDLL]:
    try:
        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt  # noqa: B018 (glibc, or another C library that has it)
    except (OSError, AttributeError):
        return None
    return libc


_SET = False
_RETAIN: Optional[int] = None  # bytes of free memory kept, once reuse_freed_memory set it


def reuse_freed_memory(memory_bytes: Optional[int] = None) -> None:
    """Keeps freed memory in this process for the next task (once per process; see the
    module docstring): up to RETAIN_SHARE of ``memory_bytes`` (the memory the process
    may use; the machine's when None) and RETAIN_MAX_BYTES, never under
    MMAP_THRESHOLD_BYTES."""
    global _SET, _RETAIN
    if _SET:
        return
    _SET = True
    libc = _glibc()
    if libc is None:
        return
    if not memory_bytes:
        memory_bytes = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    _RETAIN = max(MMAP_THRESHOLD_BYTES, int(min(RETAIN_MAX_BYTES, RETAIN_SHARE * memory_bytes)))
    libc.mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
    libc.mallopt(_M_TRIM_THRESHOLD, _RETAIN)
    libc.mallopt(_M_TOP_PAD, TOP_PAD_BYTES)
    from . import _core

    _core._set_view_by_view_allocation(True)


def release_excess() -> None:
    """After a task: when the process keeps more free memory than :func:`reuse_freed_memory`
    allows (its thread arenas give none back), returns all of it to the system (glibc's
    malloc_trim); the next task faults its pages in again."""
    libc = _glibc()
    if _RETAIN is None or libc is None or not hasattr(libc, "malloc_trim"):
        return
    if free_heap_bytes() > _RETAIN:
        libc.malloc_trim(ctypes.c_size_t(0))


def _is_thread_heap(memory: int, start: int, end: int) -> bool:
    """Whether the read-write mapping [start, end) is (part of) a glibc thread arena's
    heap: the multiple of THREAD_HEAP_BYTES at or below ``start`` holds glibc's
    heap_info {arena, previous heap, size, mprotect_size} (malloc/arena.c), sizes within
    a heap's. A heap can show as several mappings: madvise of part of it (numpy asks
    for huge pages for its large arrays) splits the kernel's record of it. Read through
    /proc/self/mem (file descriptor ``memory``), not at the address: another thread may
    unmap the region meanwhile, which is then an error here, not a crash."""
    base = start - start % THREAD_HEAP_BYTES
    if end - base > 2 * THREAD_HEAP_BYTES:
        return False
    try:
        header = os.pread(memory, 4 * ctypes.sizeof(ctypes.c_size_t), base)
    except OSError:
        return False
    if len(header) < 4 * ctypes.sizeof(ctypes.c_size_t):
        return False
    arena, _, size, mprotect_size = (ctypes.c_size_t * 4).from_buffer_copy(header)
    return arena != 0 and 0 < size <= mprotect_size <= THREAD_HEAP_BYTES


def _heap_resident_bytes(libc: ctypes.CDLL) -> Optional[int]:
    """Resident bytes of the allocator's heaps: the main arena's (``[heap]`` in
    /proc/self/maps) and the thread arenas' (anonymous read-write mappings within a
    heap, which glibc maps at multiples of THREAD_HEAP_BYTES), page by page with mincore(2);
    None without /proc. (/proc/self/smaps says the same but takes 5-10 times longer.)"""
    try:
        with open("/proc/self/maps") as maps:
            lines = maps.read().splitlines()
    except OSError:
        return None
    try:
        memory = os.open("/proc/self/mem", os.O_RDONLY)
    except OSError:
        memory = -1  # then no mapping counts as a thread heap
    page = os.sysconf("SC_PAGE_SIZE")
    libc.mincore.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p]
    resident = 0
    try:
        for line in lines:  # start-end perms offset dev inode [path]
            fields = line.split()
            path = fields[5] if len(fields) > 5 else ""
            start, end = (int(address, 16) for address in fields[0].split("-"))
            if not (path == "[heap]" or (fields[1] == "rw-p" and fields[4] == "0" and not path
                                         and memory >= 0 and _is_thread_heap(memory, start, end))):
                continue
            pages = np.zeros((end - start + page - 1) // page, np.uint8)
            if libc.mincore(start, end - start, pages.ctypes.data) == 0:
                resident += int(np.count_nonzero(pages & 1)) * page
    finally:
        if memory >= 0:
            os.close(memory)
    return resident


def free_heap_bytes() -> int:
    """Bytes of the allocator's free memory that are resident (glibc's mallinfo2): memory
    this process holds that its next allocations reuse; 0 where that is unknown. Free
    memory whose pages were never used (TOP_PAD_BYTES reserves such) is not counted:
    the resident heap less the memory in use, at most mallinfo2's ``fordblks``."""
    libc = _glibc()
    mallinfo2 = getattr(libc, "mallinfo2", None)
    if mallinfo2 is None:
        return 0
    mallinfo2.restype = _MallInfo2
    info = mallinfo2()
    resident = _heap_resident_bytes(libc)
    if resident is None:
        return int(info.fordblks)
    return int(max(0, min(info.fordblks, min(resident, info.arena) - info.uordblks)))


def held_bytes() -> int:
    """Memory this process holds that a task cannot use: its resident size less the
    allocator's free memory (:func:`free_heap_bytes`), at least 0."""
    import psutil

    return max(0, psutil.Process().memory_info().rss - free_heap_bytes())
