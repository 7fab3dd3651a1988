"""How clearly ``liff.io.detect_lenslet_size`` tells lenslet images from other images.

For lenslet images (HCI cotton written as ESLF, n = 9, when ../shared/data/hci/cotton is
present; Lytro-like ``synthetic.lenslet_capture`` scenes, n = 9 to 16, with and without
alpha; ``textured_layers`` written by ``write_eslf`` without any vignetting) and for
images that are not (cotton's centre view and its mosaic; noise of several sizes), and
``liff synth disks`` (low contrast, no vignetting) as ESLF and as mosaics,
prints each profile's best period and the share of its variance that period explains
(detrended, chance-adjusted; see ``liff.io.eslf.periodicity``), and the decision. The
thresholds in liff/io/eslf.py (0.3, or 0.2 with a size that divides the image, on both
axes at one period) sit between the two.

Usage:  python benchmarks/lenslet_size.py [--scene DIR]
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from liff import io, synthetic
from liff.io.eslf import _profiles, best_period, periodicity

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hci_depth import DEFAULT_SCENE  # noqa: E402


def eslf_image(lf: np.ndarray) -> np.ndarray:
    """(T, S, V, U[, C]) with T = S = n as the ESLF image (V n, U n[, C])."""
    T, S, V, U = lf.shape[:4]
    return lf.transpose((2, 0, 3, 1) + tuple(range(4, lf.ndim))).reshape((V * T, U * S) + lf.shape[4:])


def cases(scene: str):
    """(label, is a lenslet image, image)."""
    if os.path.isdir(scene):
        lf = io.read_hci(scene).light_field
        yield "cotton as ESLF, n = 9", True, eslf_image(lf)
        yield "cotton centre view", False, lf[4, 4]
        T, S, V, U = lf.shape[:4]
        yield "cotton mosaic", False, lf.swapaxes(1, 2).reshape(T * V, S * U, 3)
    for n in (9, 13, 14, 15, 16):
        capture = synthetic.lenslet_capture(synthetic.textured_layers((n, n, 64, 80)).light_field,
                                            border=0)
        yield f"lenslet capture, n = {n}, BGRA", True, eslf_image(capture)
        yield f"lenslet capture, n = {n}, BGR", True, eslf_image(capture[..., :3])
    for n in (9, 14, 15):
        plain = synthetic.textured_layers((n, n, 64, 80)).light_field
        yield f"plain layers, n = {n}", True, eslf_image(np.round(plain * 255).astype(np.uint8))
    for views, size in ((5, (96, 128)), (5, (128, 96)), (5, (160, 240)), (7, (96, 128)),
                        (9, (96, 128)), (14, (64, 80))):  # liff synth disks, 16-bit
        shape = (views, views) + size
        lf = synthetic.render_disks(synthetic.paper_disks(shape=shape, seed=0), shape)
        lf = np.round(np.clip(lf, 0, 1) * 65535).astype(np.uint16)
        label = f"liff synth disks, {views}x{views} views of {size[0]}x{size[1]}"
        yield f"{label}, as ESLF", True, eslf_image(lf)
        yield f"{label}, mosaic", False, lf.swapaxes(1, 2).reshape(views * size[0], views * size[1])
    rng = np.random.default_rng(0)
    for size in ((40, 45), (64, 64), (900, 1000, 3)):
        yield f"noise {'x'.join(map(str, size))}", False, rng.integers(0, 256, size, dtype=np.uint8)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default=DEFAULT_SCENE)
    args = parser.parse_args(argv)
    print("| image | lenslet image | profiles: best period (share) | decision |")
    print("|---|---|---|---|")
    for label, lenslet, image in cases(args.scene):
        has_alpha = image.ndim == 3 and image.shape[2] in (2, 4)
        evidence = {name: best_period(periodicity(profile))
                    for name, profile in _profiles(image if image.ndim == 3 else image[..., None],
                                                   has_alpha).items()}
        shown = ", ".join(f"{name} {n if n else '-'} ({score:.2f})" for name, (n, score) in evidence.items())
        try:
            decision = f"n = {io.detect_lenslet_size(image)[0]}"
        except ValueError:
            decision = "refused: cannot tell"
        print(f"| {label} | {'yes' if lenslet else 'no'} | {shown} | {decision} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
