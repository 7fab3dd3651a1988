"""Only regular files and folders are read or replaced.

Opening a FIFO blocks until a writer comes (forever, for a FIFO left in place of an
input or an output), and a device or socket is no light field either: every path liff
reads, checks or replaces is refused at once, without opening it, if it exists and is
neither a regular file nor a folder (a symbolic link counts as what it points to).
"""

from __future__ import annotations

import os
import stat
from typing import Optional, Union

PathLike = Union[str, os.PathLike]

_KINDS = ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"))


def special_kind(path: PathLike) -> Optional[str]:
    """"a FIFO", "a socket", ... if ``path`` exists and is neither a regular file nor a
    folder; None if it is one of those or does not exist (``os.stat`` opens nothing)."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):  # missing, a dangling link, no permission, a NUL byte
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    return next((kind for test, kind in _KINDS if test(mode)), "not a regular file")


def refuse_special(path: PathLike, expected: str) -> None:
    """Raises ValueError ``"PATH: is a FIFO, not a regular file or folder; expected
    EXPECTED"`` if ``path`` is such a thing (:func:`special_kind`)."""
    kind = special_kind(path)
    if kind is not None:
        raise ValueError(f"{os.fspath(path)}: is {kind}, not a regular file or folder; "
                         f"expected {expected}")
