"""Light fields for the benchmarks: textured, occluding fronto-parallel layers."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from liff.synthetic import textured_layers

ILLUM_SHAPE = (11, 11, 376, 541)  # Lytro Illum: 11x11 views of 376x541 pixels

#: The HCI cotton scene of the shared data (../shared/data/hci/cotton, beside the
#: repository; the benchmarks that use it skip it, or say so, where it is absent).
COTTON = Path(__file__).resolve().parents[2] / "shared" / "data" / "hci" / "cotton"


def layered_light_field(shape=ILLUM_SHAPE, seed=0, noise_variance=1e-4) -> np.ndarray:
    """liff.synthetic.textured_layers at slopes -0.6, 0.1 and 0.7: float32 (T, S, V, U)."""
    return textured_layers(shape, (-0.6, 0.1, 0.7), seed, noise_variance).light_field
