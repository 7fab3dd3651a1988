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
from typing import Optional, Union

import cv2
import numpy as np

from .pfm import read_pfm

PathLike = Union[str, os.PathLike]
_VIEW = re.compile(r"^input_Cam(\d{3})\.png$")


@dataclass
class HciScene:
    """An HCI scene: ``light_field`` (T, S, V, U, 3) uint8 BGR, the scene's disparity
    range, its ground-truth disparity (V, U) float32 if present, and parameters.cfg."""

    light_field: np.ndarray
    disp_min: Optional[float]
    disp_max: Optional[float]
    gt_disparity: Optional[np.ndarray]
    parameters: dict = field(default_factory=dict)


def read_hci(folder: PathLike) -> HciScene:
    """Reads an HCI scene folder.

    Raises
    ------
    ValueError
        Naming the folder or file: no views, missing views, views of mixed sizes,
        unreadable images, or a parameters.cfg whose grid disagrees with the views.
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

    parameters, T, S = {}, None, None
    cfg_path = os.path.join(folder, "parameters.cfg")
    if os.path.isfile(cfg_path):
        cfg = configparser.ConfigParser()
        try:
            cfg.read(cfg_path)
        except configparser.Error as e:
            raise ValueError(f"{cfg_path}: unreadable ({e})") from None
        parameters = {s: dict(cfg[s]) for s in cfg.sections()}
        ext = parameters.get("extrinsics", {})
        if "num_cams_x" in ext and "num_cams_y" in ext:
            S, T = int(ext["num_cams_x"]), int(ext["num_cams_y"])
    if T is None:  # no grid given: a square grid of all views
        n = int(round(np.sqrt(len(views))))
        if n * n != len(views):
            raise ValueError(f"{folder}: {len(views)} views and no parameters.cfg grid; expected "
                             f"a square number of views")
        T = S = n
    missing = sorted(set(range(T * S)) - set(views))
    if missing:
        raise ValueError(f"{folder}: views missing for a {T}x{S} grid: "
                         f"{', '.join(f'input_Cam{i:03d}.png' for i in missing[:5])}"
                         f"{' ...' if len(missing) > 5 else ''}")
    first = None
    lf = None
    for index in range(T * S):
        image = cv2.imread(views[index], cv2.IMREAD_COLOR)
        if image is None:
            raise ValueError(f"{views[index]}: unreadable image")
        if first is None:
            first = image.shape
            lf = np.empty((T, S) + first, np.uint8)
        elif image.shape != first:
            raise ValueError(f"{views[index]}: size {image.shape[1]}x{image.shape[0]} differs "
                             f"from the first view's {first[1]}x{first[0]}")
        lf[index // S, index % S] = image

    meta = parameters.get("meta", {})
    disp_min = float(meta["disp_min"]) if "disp_min" in meta else None
    disp_max = float(meta["disp_max"]) if "disp_max" in meta else None
    gt_path = os.path.join(folder, "gt_disp_lowres.pfm")
    gt = read_pfm(gt_path) if os.path.isfile(gt_path) else None
    if gt is not None and gt.shape != first[:2]:
        raise ValueError(f"{gt_path}: size {gt.shape[1]}x{gt.shape[0]} differs from the views' "
                         f"{first[1]}x{first[0]}")
    return HciScene(lf, disp_min, disp_max, gt, parameters)
