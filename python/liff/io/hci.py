"""HCI 4D light field benchmark scenes (Honauer et al., ACCV 2016).

A scene folder holds ``input_CamNNN.png`` (NNN = row * S + column), ``parameters.cfg``
and, for training scenes, ``gt_disp_lowres.pfm`` (disparity of the centre view in
pixels per view step, equal to liff's slope).
"""

from __future__ import annotations

import configparser
import os
import re
from dataclasses import dataclass, field
from typing import Dict, Optional, Tuple, Union

import cv2
import numpy as np

from .._budget import array_bytes, check_fits
from .._paths import refuse_special
from ..camera import HCI_CAMERA_KEYS, LightFieldCamera
from ._shared import LightFieldFile, check_incomplete
from .images import decode_image, header_size
from .pfm import read_pfm

PathLike = Union[str, os.PathLike]
_VIEW = re.compile(r"^input_Cam(\d{3})\.png$")
MAX_VIEWS = 1000  # input_Cam000 .. input_Cam999


@dataclass
class HciScene:
    """An HCI scene: ``light_field`` (T, S, V, U, 3) uint8 BGR (BGRA with alpha 0 at
    missing views when views are missing: C = 4), the scene's disparity
    range, its ground-truth disparity (V, U) float32 if present, parameters.cfg, and
    the calibrated camera (:meth:`liff.LightFieldCamera.from_hci`) when parameters.cfg
    has the intrinsics and extrinsics it needs."""

    light_field: np.ndarray
    disp_min: Optional[float]
    disp_max: Optional[float]
    gt_disparity: Optional[np.ndarray]
    parameters: dict = field(default_factory=dict)
    camera: Optional[LightFieldCamera] = None


def _number(text: str, kind, name: str, path: str):
    """int(text) or float(text), or a ValueError naming the file and the entry."""
    try:
        value = kind(text.strip())
    except ValueError:
        raise ValueError(f"{path}: {name} = {text!r}; expected {'an integer' if kind is int else 'a number'}") from None
    if kind is float and not np.isfinite(value):
        raise ValueError(f"{path}: {name} = {text!r}; expected a finite number")
    return value


def read_hci(folder: PathLike) -> HciScene:
    """Reads an HCI scene folder.

    Raises
    ------
    ValueError
        Naming the folder or file: no views, fewer views than the grid's longer side,
        a view outside the grid, views of mixed sizes,
        unreadable images, a parameters.cfg whose grid or image resolution disagrees
        with the views or whose camera entries are out of range, or a
        gt_disp_lowres.pfm that is not a grey map of the views' size.

    Warns
    -----
    MissingViewsWarning
        When views of the grid (parameters.cfg's, else the square one whose last view
        is the last numbered) are missing, naming them: any pattern (EPINET's 33 of 81:
        centre row, column and diagonals) is read with alpha 0 at the missing views.
    """
    folder = os.fspath(folder)
    if not os.path.isdir(folder):
        raise ValueError(f"{folder}: not a folder; expected an HCI scene folder")
    views = {}
    for name in os.listdir(folder):
        m = _VIEW.match(name)
        if m:
            views[int(m.group(1))] = os.path.join(folder, name)
    if not views:
        raise ValueError(f"{folder}: no input_CamNNN.png views; expected an HCI scene folder")

    parameters: Dict[str, Dict[str, str]] = {}
    grid: Optional[Tuple[int, int]] = None  # parameters.cfg's (T, S)
    cfg_path = os.path.join(folder, "parameters.cfg")
    refuse_special(cfg_path, "an HCI parameters.cfg")
    if os.path.isfile(cfg_path):
        # No interpolation: a '%' in a value is text, not a configparser reference.
        cfg = configparser.ConfigParser(interpolation=None)
        try:
            with open(cfg_path, encoding="utf-8") as f:
                cfg.read_file(f)
        except (configparser.Error, UnicodeDecodeError) as e:
            raise ValueError(f"{cfg_path}: unreadable ({e}); expected an HCI parameters.cfg "
                             "(UTF-8 INI)") from None
        parameters = {s: dict(cfg[s]) for s in cfg.sections()}
        ext = parameters.get("extrinsics", {})
        if "num_cams_x" in ext and "num_cams_y" in ext:
            S = _number(ext["num_cams_x"], int, "extrinsics num_cams_x", cfg_path)
            T = _number(ext["num_cams_y"], int, "extrinsics num_cams_y", cfg_path)
            # A positive grid of at most 1000 views (NNN in the names): checked before
            # the missing views are listed, so a huge grid costs no memory.
            if T < 1 or S < 1 or T * S > MAX_VIEWS:
                raise ValueError(f"{cfg_path}: grid num_cams_y x num_cams_x = {T}x{S}; expected "
                                 f"a positive grid of at most {MAX_VIEWS} views")
            grid = (T, S)
    if grid is not None:
        T, S = grid
    else:  # no grid given: the square grid whose last view is the last numbered
        T = S = int(round(np.sqrt(max(views) + 1)))
        if T * S != max(views) + 1:
            raise ValueError(f"{folder}: views numbered up to input_Cam{max(views):03d}.png and no "
                             f"parameters.cfg grid; expected a square number of views (the last "
                             f"one's number + 1), or parameters.cfg's num_cams_x and num_cams_y")
    views = {i: path for i, path in views.items() if i < T * S}  # (parameters.cfg's grid)
    if not views:
        raise ValueError(f"{folder}: no input_CamNNN.png view inside the {T}x{S} grid of "
                         f"parameters.cfg; expected input_Cam000 .. input_Cam{T * S - 1:03d}")
    complete = len(views) == T * S
    if not complete:  # any pattern (EPINET's 33 of 81): alpha 0 where views are missing
        check_incomplete(folder, (T, S), len(views), (f"input_Cam{i:03d}.png" for i in range(T * S)
                                                      if i not in views))
    channels = 3 if complete else 4  # BGR, or BGR + alpha
    first: Optional[Tuple[int, ...]] = None  # the first view's shape
    lf: Optional[np.ndarray] = None
    for index in sorted(views):
        refuse_special(views[index], "an HCI view (PNG image)")
        size = header_size(views[index])
        if first is None and size is not None:  # BGR uint8, as IMREAD_COLOR decodes
            check_fits(folder, array_bytes((T, S, size.height, size.width, channels), 1),
                       f"a light field of {T}x{S} views of {size.width}x{size.height} "
                       f"{'BGR' if complete else 'BGRA'}")
        elif first is not None and size is not None and size.height * size.width > first[0] * first[1]:
            raise _size_differs(views[index], (size.height, size.width), first, " (its header)")
        image = decode_image(views[index], cv2.IMREAD_COLOR)
        if image is None:
            raise ValueError(f"{views[index]}: unreadable image")
        if first is None:
            first = image.shape
            lf = (np.empty if complete else np.zeros)((T, S) + first[:2] + (channels,), np.uint8)
        elif image.shape != first:
            raise _size_differs(views[index], image.shape, first)
        assert lf is not None  # (allocated with the first view)
        lf[index // S, index % S, ..., :3] = image
        if not complete:
            lf[index // S, index % S, ..., 3] = 255

    assert first is not None and lf is not None  # (views is not empty)
    meta = parameters.get("meta", {})
    disp_min = _number(meta["disp_min"], float, "meta disp_min", cfg_path) if "disp_min" in meta else None
    disp_max = _number(meta["disp_max"], float, "meta disp_max", cfg_path) if "disp_max" in meta else None
    gt_path = os.path.join(folder, "gt_disp_lowres.pfm")
    refuse_special(gt_path, "an HCI disparity map (PFM)")
    gt = read_pfm(gt_path) if os.path.isfile(gt_path) else None
    if gt is not None and gt.ndim != 2:
        raise ValueError(f"{gt_path}: colour (PF) PFM of shape {gt.shape}; expected a grey Pf "
                         f"disparity map of the views' size {first[1]}x{first[0]}")
    if gt is not None and gt.shape != first[:2]:
        raise ValueError(f"{gt_path}: size {gt.shape[1]}x{gt.shape[0]} differs from the views' "
                         f"{first[1]}x{first[0]}")
    camera = None
    if all(key in parameters.get(section, {}) for section, key in HCI_CAMERA_KEYS):
        camera = LightFieldCamera.from_hci_parameters(parameters, cfg_path)
        if (camera.principal_point[0] * 2 + 1, camera.principal_point[1] * 2 + 1) != (first[1], first[0]):
            raise ValueError(f"{cfg_path}: image_resolution {camera.principal_point[0] * 2 + 1:g}x"
                             f"{camera.principal_point[1] * 2 + 1:g} differs from the views' "
                             f"{first[1]}x{first[0]}")
    return HciScene(lf, disp_min, disp_max, gt, parameters, camera)


def read_hci_light_field(folder: PathLike) -> LightFieldFile:
    """:func:`read_hci` as every reader returns: a :class:`LightFieldFile` whose
    ``metadata`` holds ``disp_min``, ``disp_max``, ``parameters`` and ``camera``."""
    scene = read_hci(folder)
    metadata = {"disp_min": scene.disp_min, "disp_max": scene.disp_max,
                "parameters": scene.parameters, "camera": scene.camera}
    return LightFieldFile(scene.light_field, "hci", metadata, scene.gt_disparity,
                          os.fspath(folder))


def is_hci_scene(names) -> bool:
    """Whether a folder holding the files ``names`` is an HCI scene (its views' names)."""
    return any(_VIEW.match(name) for name in names)


def _size_differs(path: str, shape, first, how: str = "") -> ValueError:
    """The error for a view of ``shape`` (V, U, ...) unlike the first view's ``first``."""
    return ValueError(f"{path}: size {shape[1]}x{shape[0]}{how} differs from the first "
                      f"view's {first[1]}x{first[0]}")
