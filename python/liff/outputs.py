"""Writing outputs without losing data: never over an input, never half written.

Every file liff's command line and :mod:`liff.batch` write goes through
:func:`atomic_output`: the writer fills a temporary file in the destination's folder,
which is renamed over the destination (``os.replace``, atomic on POSIX) only once it
is complete. A run killed at any moment leaves the old file or the new one, never a
truncated one (at most a hidden ``.NAME.*.partial*`` file beside it). Missing folders
are created. :func:`refuse_inputs` refuses an output that is one of the inputs, by any
spelling (relative path, symbolic link, hard link) or that lies inside an input folder.
Only regular files and folders are replaced: a FIFO, socket or device in the way is
refused (:func:`liff._paths.refuse_special`), before anything opens it.
"""

from __future__ import annotations

import os
import shutil
import uuid
from contextlib import contextmanager
from typing import Iterable, Iterator, Union

from ._paths import refuse_special

PathLike = Union[str, os.PathLike]


def make_folder(folder: PathLike) -> None:
    """Creates ``folder`` and its parents if missing.

    Raises
    ------
    ValueError
        Naming the folder, if it cannot be created (a file in the way, no permission).
    """
    folder = os.fspath(folder)
    if not folder or os.path.isdir(folder):
        return
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as error:
        raise ValueError(f"{folder}: cannot create the folder ({error.strerror or error}); "
                         "expected a writable place for the outputs") from None


def temporary_name(path: PathLike) -> str:
    """A hidden name beside ``path`` with the same ending (writers such as OpenCV's
    and numpy's pick the format from it): ``a/b.png`` -> ``a/.b.png.<random>.partial.png``."""
    folder, base = os.path.split(os.path.abspath(os.fspath(path)))
    ending = os.path.splitext(base)[1]
    return os.path.join(folder, f".{base}.{uuid.uuid4().hex[:8]}.partial{ending}")


@contextmanager
def atomic_output(path: PathLike, folder: bool = False) -> Iterator[str]:
    """Yields a temporary path to write ``path``'s content to; renames it to ``path``
    when the block ends without an exception, removes it otherwise.

    Parameters
    ----------
    path : path
        The destination; its folder is created if missing.
    folder : bool
        The output is a folder (e.g. a light field as one image per view): the block
        fills the yielded folder, which then replaces ``path`` whole (an old folder at
        ``path`` is removed only after the new one is in place).

    Raises
    ------
    ValueError
        If the destination's folder cannot be created or ``path`` is a FIFO, socket or
        device; a writer's ValueError comes back naming ``path`` instead of the
        temporary file.
    """
    path = os.fspath(path)
    refuse_special(path, "a regular file or folder to replace, or a new path")
    make_folder(os.path.dirname(os.path.abspath(path)))
    temporary = temporary_name(path)
    if folder:
        os.mkdir(temporary)
    try:
        yield temporary
        if folder and os.path.isdir(path):
            old = temporary_name(path)
            os.replace(path, old)
            os.replace(temporary, path)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(temporary, path)
    except ValueError as error:  # a writer's message names the temporary file
        _remove(temporary)
        raise ValueError(str(error).replace(temporary, path)) from None
    except BaseException:
        _remove(temporary)
        raise


def _remove(path: str) -> None:
    if os.path.isdir(path) and not os.path.islink(path):
        shutil.rmtree(path, ignore_errors=True)
    elif os.path.lexists(path):
        os.remove(path)


def refuse_inputs(outputs: Iterable[PathLike], inputs: Iterable[PathLike],
                  option: str = "--out") -> None:
    """Raises ValueError if an output would write over an input.

    An output is refused if it is the same file as an input (same path, another
    spelling, a symbolic or a hard link) or lies inside an input folder (a folder of
    views or an HCI scene: a file added there changes the light field).

    Parameters
    ----------
    outputs, inputs : iterables of paths
    option : str
        The option that chose the outputs, for the message.
    """
    outputs = [os.fspath(o) for o in outputs]
    for output in outputs:
        refuse_special(output, f"a regular file or folder for {option}, or a new path")
    inputs = [os.fspath(i) for i in inputs if os.path.exists(i)]
    folders = [os.path.realpath(i) + os.sep for i in inputs if os.path.isdir(i)]
    for output in outputs:
        same = next((i for i in inputs if os.path.exists(output) and os.path.samefile(output, i)),
                    None)
        inside = next((f for f in folders if os.path.realpath(output).startswith(f)), None)
        if same is not None or inside is not None:
            what = (f"is the input {same}" if same is not None else
                    f"lies inside the input folder {str(inside).rstrip(os.sep)}")
            raise ValueError(f"{output}: {what}; expected an output that is not an input "
                             f"(choose another {option}); nothing was written")
