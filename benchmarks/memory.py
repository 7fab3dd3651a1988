"""Memory estimate against measured memory: the estimate a detectAndCompute call checks
its memory limit with (cpp/src/memory.hpp), and how much the process's peak resident
memory grows during the call, each case in a fresh process.

Usage:
    python benchmarks/memory.py            # the table in docs/RELIABILITY.md (a few minutes;
                                           # the 12 MP cases peak at about 3 GB)
    python benchmarks/memory.py --quick    # the small cases only (seconds)
    python benchmarks/memory.py --case 1x1x3000x4000:u8:fo-1:t2:texture   # one case

A case is ``TxSxVxU:DTYPE:foF:tN:CONTENT`` with DTYPE u8 (grey), u8c3 (BGR), u16 or f32,
F the first octave (-1 or 0), N the core's threads (liff.setNumThreads) and CONTENT
``texture`` (smoothed noise of 2 px seen as three layers at slopes -0.6, 0.1, 0.7:
structure the automatic range finds; for one view, that noise), ``dense`` and ``sparse``
(a plane at slope 0.5 of smoothed noise of 1 and 12 px: the most keypoints per pixel
measured, and few) or ``noise`` (uniform noise, in which the survey finds nothing).

Peak: ``VmHWM`` after the call less ``VmRSS`` just before it, with the high-water mark
reset to the resident size first (``/proc/self/clear_refs``), in a process that has made
its input, imported liff and run one tiny detection (cv2's own first-call set-up) and
nothing else. So the figure is everything the call adds: the core's buffers, the
allocator's overheads, the returned keypoints and descriptors.
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import json
import os
import subprocess
import sys
import warnings
from dataclasses import dataclass
from typing import Dict, List, Optional

import numpy as np

MB = 2.0 ** 20

#: The cases of the docs' table: single images (1x1 views) at about 1, 4 and 12 MP and
#: light fields of three sizes and dtypes, first octave -1 and 0, one and two threads.
TABLE = [
    "1x1x864x1152:u8:fo-1:t1:texture",
    "1x1x864x1152:u8:fo-1:t2:texture",
    "1x1x864x1152:u8:fo0:t2:texture",
    "1x1x1728x2304:u8c3:fo-1:t2:texture",
    "1x1x3000x4000:u8:fo-1:t1:texture",
    "1x1x3000x4000:u8:fo-1:t2:texture",
    "1x1x3000x4000:u8:fo0:t2:texture",
    "1x1x3000x4000:u8:fo-1:t2:noise",
    "1x1x864x1152:u8:fo-1:t2:dense",
    "1x1x864x1152:u8:fo-1:t2:sparse",
    "1x1x864x1152:u8:fo0:t2:sparse",
    "5x5x256x256:u8:fo-1:t1:texture",
    "5x5x256x256:u8:fo-1:t2:texture",
    "5x5x256x256:u8:fo0:t2:texture",
    "5x5x256x256:f32:fo-1:t2:noise",
    "9x9x512x512:u8c3:fo-1:t1:texture",
    "9x9x512x512:u8c3:fo-1:t2:texture",
    "9x9x512x512:u8c3:fo0:t2:texture",
    "11x11x376x541:f32:fo-1:t1:texture",
    "11x11x376x541:f32:fo-1:t2:texture",
    "11x11x376x541:f32:fo0:t2:texture",
    "11x11x376x541:u8:fo-1:t2:noise",
]

#: The small cases (each under a second and 300 MB, typical content): in
#: tests/core/test_memory_estimate.py.
QUICK = [case for case in TABLE if case.startswith(("5x5x", "1x1x864x")) and "sparse" not in case
         and "dense" not in case]

#: Too large to run here (about 11 GB): the estimate only.
ESTIMATE_ONLY = [(6000, 8000)]


@dataclass
class Case:
    shape: tuple
    dtype: str
    first_octave: int
    threads: int
    content: str

    @classmethod
    def parse(cls, text: str) -> "Case":
        try:
            shape, dtype, octave, threads, content = text.split(":")
            dims = tuple(int(n) for n in shape.split("x"))
            if len(dims) != 4 or min(dims) < 1 or not octave.startswith("fo") \
                    or not threads.startswith("t") or dtype not in ("u8", "u8c3", "u16", "f32") \
                    or content not in ("texture", "dense", "sparse", "noise"):
                raise ValueError
            return cls(dims, dtype, int(octave[2:]), int(threads[1:]), content)
        except ValueError:
            raise ValueError(f"case {text!r}: expected TxSxVxU:DTYPE:foF:tN:CONTENT, e.g. "
                             f"5x5x256x256:u8:fo-1:t2:texture (DTYPE u8, u8c3, u16 or f32; "
                             f"CONTENT texture, dense, sparse or noise)") from None

    def light_field(self) -> np.ndarray:
        """The input: float32 in [0, 1] converted to the case's dtype and channels."""
        from liff import synthetic

        T, S, V, U = self.shape
        if self.content == "noise":
            grey = np.random.default_rng(0).random(self.shape, dtype=np.float32)
        elif T * S == 1 or self.content != "texture":
            blur = dict(texture=2.0, dense=1.0, sparse=12.0)[self.content]
            grey = synthetic.textured_plane(self.shape, slope=0.0 if T * S == 1 else 0.5,
                                            blur=blur)
        else:
            grey = synthetic.textured_layers(self.shape).light_field
        if T * S == 1:
            grey = grey[0, 0]
        if self.dtype == "f32":
            return grey
        scale = 255 if self.dtype.startswith("u8") else 65535
        out = np.round(grey * scale).astype(np.uint8 if scale == 255 else np.uint16)
        return np.repeat(out[..., None], 3, axis=-1) if self.dtype == "u8c3" else out


def _status(key: str) -> float:
    """A /proc/self/status figure (kB), in bytes."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(key + ":"):
                return float(line.split()[1]) * 1024.0
    raise RuntimeError(f"/proc/self/status has no {key}")


def _child(text: str) -> Dict[str, float]:
    """Runs one case in this process (a fresh one): the call's estimate and peak growth."""
    import liff

    case = Case.parse(text)
    lf = case.light_field()
    liff.setNumThreads(case.threads)
    warnings.simplefilter("ignore")  # noise: the automatic range says it found nothing
    detector = liff.LiFF.create(firstOctave=case.first_octave)
    detector.detectAndCompute(np.zeros((32, 32), np.uint8), None)  # cv2's first-call set-up
    gc.collect()
    ctypes.CDLL(None).malloc_trim(0)  # what making the input freed is not reused unseen
    with open("/proc/self/clear_refs", "w") as clear:
        clear.write("5")  # VmHWM = VmRSS from here on
    before = _status("VmRSS")
    core_before = liff._core._hooks.working_memory_peak(reset=True)  # what the set-up keeps
    keypoints, descriptors = detector.detectAndCompute(lf, None)
    peak = _status("VmHWM") - before
    core = liff._core._hooks.working_memory_peak() - core_before
    estimate = liff._core._hooks.memory_estimate(detector)
    return dict(peak=peak, core=core, estimate=estimate["total"], batch=estimate["batch"],
                keypoints=len(keypoints), slices=len(detector.getSlicesUsed()),
                input=lf.nbytes)


def measure(text: str, timeout: Optional[float] = None) -> Dict[str, float]:
    """Runs case ``text`` in a fresh Python process (``nice -n 10``) and returns its
    figures: peak (bytes the peak resident size grew during the call), estimate (bytes,
    the core's, for the slices it built at once), batch, keypoints, slices, input."""
    Case.parse(text)  # a bad case fails here, with its message
    env = dict(os.environ)
    package = os.path.dirname(os.path.dirname(os.path.abspath(__import__("liff").__file__)))
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package, env.get("PYTHONPATH")) if p)
    done = subprocess.run(["nice", "-n", "10", sys.executable, os.path.abspath(__file__),
                           "--child", text], env=env, capture_output=True, text=True,
                          timeout=timeout)
    if done.returncode != 0:
        raise RuntimeError(f"case {text} failed (exit {done.returncode}):\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def table(cases: List[str]) -> List[str]:
    """The markdown table of docs/RELIABILITY.md, one row per case as it is measured."""
    rows = ["| case | input MB | slices | batch | keypoints | estimate MB | core's peak MB | peak MB "
            "| estimate / peak |",
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for line in rows:
        print(line, flush=True)
    for case in cases:
        r = measure(case)
        row = (f"| `{case}` | {r['input'] / MB:,.0f} | {r['slices']} | {r['batch']} | "
               f"{r['keypoints']:,} | {r['estimate'] / MB:,.0f} | {r['core'] / MB:,.0f} | {r['peak'] / MB:,.0f} | "
               f"{r['estimate'] / r['peak']:.2f} |")
        print(row, flush=True)
        rows.append(row)
    return rows


def estimate_only(height: int, width: int) -> float:
    """The estimate (MB) of detectAndCompute for one uint8 view of height x width, from
    the MemoryError of a call that cannot fit in 1 kB (nothing large is allocated)."""
    import re

    import liff

    detector = liff.LiFF.create()
    detector.setMemoryLimitMB(1e-3)
    try:
        detector.detectAndCompute(np.zeros((height, width), np.uint8), None)
    except MemoryError as error:
        return float(re.search(r"needs about (\d+) MB", str(error)).group(1))
    raise RuntimeError("expected a MemoryError")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="the small cases only")
    parser.add_argument("--case", action="append", help="a case to run (repeatable)")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(_child(args.child)))
        return 0
    table(args.case or (QUICK if args.quick else TABLE))
    if not (args.case or args.quick):
        for height, width in ESTIMATE_ONLY:
            print(f"\n{height * width / 1e6:.0f} MP ({height} x {width}, uint8, one view), not "
                  f"run: estimate {estimate_only(height, width):,.0f} MB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
