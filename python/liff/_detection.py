"""One light field's detection as ``liff detect`` and the batch runs make it: the input
read (any liff.io format, optionally preprocessed), the slope range (a reader's where
the user gave none), the mask (``--mask``: an image, or ``auto``) and a detector within
the process's memory budget (liff._budget).

Layer: the detector's (tests/test_layers.py): it reads with liff.io and
liff.preprocess, below it; the batch runs (liff._tasks) and the command line use it.
"""

from __future__ import annotations

import math
import os
from typing import Optional, Tuple

import numpy as np

from . import _budget, io
from ._budget import held_bytes
from ._detector import PARAMETERS, LiFF
from .io.eslf import check_given_lenslets
from .io.images import read_image
from .preprocess import border_mask, prepare

#: The slope range's create() keywords: on the command line, not giving one differs
#: from giving its default (liff detect then takes a reader's range, docs/SLOPES.md).
SLOPE_BOUNDS = ("firstSlope", "lastSlope")


def with_defaults(parameters: dict) -> dict:
    """``parameters`` with each one not given (None) at its create() default."""
    defaults = {p.name: p.default for p in PARAMETERS}
    return {name: defaults[name] if value is None else value for name, value in parameters.items()}


def slope_range(parameters: dict, metadata: dict) -> Tuple[dict, str]:
    """The create() keywords to use, and where the slope range comes from, for
    ``parameters`` whose slope bounds are None where the user gave none.

    Each bound the user gave is kept (-inf / inf: automatic at that end); each one not
    given comes from the range a reader knows (an HCI scene's parameters.cfg disp_min
    and disp_max) if it has one and it does not cross the bound given, else is
    automatic. The source says which: "given" (finite bounds given), "parameters.cfg",
    "automatic", or two of them joined by " + " (given first)."""
    lo, hi = metadata.get("disp_min"), metadata.get("disp_max")
    hint = ({"firstSlope": float(lo), "lastSlope": float(hi)}
            if lo is not None and hi is not None and lo < hi else {})
    given = {name: parameters[name] for name in SLOPE_BOUNDS if parameters.get(name) is not None}
    if len(given) == 1 and hint:  # the reader's other end only where it keeps the order
        (name, value), = given.items()
        other = "lastSlope" if name == "firstSlope" else "firstSlope"
        if (hint[other] > value) != (other == "lastSlope"):
            hint = {}
    resolved, sources = dict(parameters, **hint), []
    for name in SLOPE_BOUNDS:
        if name in given:
            resolved[name] = given[name]
            sources.append("given" if math.isfinite(given[name]) else "automatic")
        else:
            sources.append("parameters.cfg" if name in hint else "automatic")
    order = ["given", "parameters.cfg", "automatic"]
    return with_defaults(resolved), " + ".join(sorted(set(sources), key=order.index))


def make_detector(parameters: dict) -> LiFF:
    """A detector with ``parameters``; under a ``liff._budget.memory_budget_bytes``, its memory
    limit (setMemoryLimitMB) is what the budget leaves of what the process holds now,
    so a light field read before the detector is made counts against the budget."""
    detector = LiFF.create(**parameters)
    budget = _budget.memory_budget_bytes
    if budget is not None:
        held = held_bytes()
        if held >= budget:
            raise MemoryError(f"the process holds {held / 1e6:.0f} MB with the light field "
                              f"read, all of its memory budget of {budget / 1e6:.0f} "
                              "MB, leaving LiFF none; expected more memory for the task")
        detector.setMemoryLimitMB(max(1, int((budget - held) / 2**20)))
    return detector


def read_input(path: str, options: dict, preprocess: bool) -> Tuple[np.ndarray, dict]:
    """Reads a light field (any liff.io format), optionally preprocessed, and the
    reader's metadata (e.g. an HCI scene's disparity range and camera). A lenslet image
    read with ``--lenslet`` must hold 8 lenslets a side
    (:func:`liff.io.eslf.check_given_lenslets`)."""
    read = io.read_light_field(path, **options)
    check_given_lenslets(read)  # --lenslet: at least 8 lenslets a side
    light_field = read.light_field
    if preprocess:
        light_field = prepare(light_field)
    return light_field, read.metadata


AUTO = "auto"


def load_mask(spec: Optional[str], light_field: np.ndarray, source: str) -> Optional[np.ndarray]:
    """The detection mask for ``light_field`` (read from ``source``): None without
    ``--mask``, :func:`liff.preprocess.border_mask` for ``auto``, else the image at
    ``spec`` as uint8 (V, U), 255 where any colour channel is non-zero.

    Raises
    ------
    ValueError
        Naming the mask file: unreadable, or not of the views' size.
    """
    if spec is None:
        return None
    if spec == AUTO:
        return border_mask(light_field)
    try:
        image = read_image(spec)
    except ValueError as error:  # (the message names the file; say which option gave it)
        raise ValueError(f"--mask: {error}") from None
    if image.ndim == 3:  # the colour channels; alpha (C = 2 or 4) is not part of the mask
        image = image[..., : 1 if image.shape[2] == 2 else 3].max(axis=2)
    V, U = light_field.shape[2:4]
    if image.shape != (V, U):
        raise ValueError(f"{os.fspath(spec)}: mask is {image.shape[1]}x{image.shape[0]} (width x "
                         f"height); expected the views' size {U}x{V} of {source}")
    return np.where(image != 0, 255, 0).astype(np.uint8)
