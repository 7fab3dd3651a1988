#!/usr/bin/env bash
# AddressSanitizer + UndefinedBehaviorSanitizer (CMake option LIFF_SANITIZE).
#
# Builds, in build/sanitize, the C++ library with its tests (ctest) and the Python
# module liff._core, all with -fsanitize=address,undefined -fno-sanitize-recover=undefined;
# runs ctest, then (unless LIFF_SANITIZE_PYTHON=0) the Python test suite against the
# sanitized _core, with libasan/libubsan preloaded into the interpreter. Any sanitizer
# report stops the run with a non-zero exit (halt_on_error; UBSan does not recover).
#
# Needs .venv (made by .ci/setup.sh) with liff's Python dependencies installed.
#   LIFF_SANITIZE_PYTHON=0   C++ tests only
#   PYTEST_ARGS="tests/detector/test_random_inputs.py -x"   what pytest runs (default: tests)
set -euo pipefail
cd "$(dirname "$0")/.."
py=.venv/bin/python
[ -x "$py" ] || { echo "sanitize: no .venv; run 'bash .ci/setup.sh test' first" >&2; exit 2; }
"$py" -m pip install -q --disable-pip-version-check cmake ninja "pybind11>=2.12"
export PATH="$PWD/.venv/bin:$PATH"

build=build/sanitize
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DLIFF_SANITIZE=ON -DLIFF_BUILD_TESTS=ON -DLIFF_BUILD_PYTHON=ON \
  -DPython_EXECUTABLE="$PWD/$py" -Dpybind11_DIR="$("$py" -m pybind11 --cmakedir)" >/dev/null
cmake --build "$build"
# (grep reads all of nm's output: with -q, nm's SIGPIPE would fail the pipeline)
nm -D "$build"/_core*.so | grep __asan_report >/dev/null ||
  { echo "sanitize: $build/_core is not instrumented" >&2; exit 1; }

export ASAN_OPTIONS="halt_on_error=1:abort_on_error=1:detect_leaks=0:strict_string_checks=1:detect_stack_use_after_return=1:check_initialization_order=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"

# The C++ tests: the binary links the sanitizer runtimes itself (leak checks on).
ASAN_OPTIONS="${ASAN_OPTIONS/detect_leaks=0/detect_leaks=1}" \
  ctest --test-dir "$build" --output-on-failure

[ "${LIFF_SANITIZE_PYTHON:-1}" = 0 ] && exit 0

# The Python suite against the sanitized module: a copy of the pure-Python package
# with the sanitized _core beside it, first on PYTHONPATH. The interpreter is not
# instrumented, so the runtimes are preloaded; leak checks are off (CPython and numpy
# keep allocations alive until exit by design).
pkg="$build/python"
rm -rf "$pkg"
mkdir -p "$pkg"
cp -r python/liff "$pkg/liff"
find "$pkg/liff" \( -name '*.so' -o -name __pycache__ \) -prune -exec rm -rf {} +
cp "$build"/_core*.so "$pkg/liff/"
export LD_PRELOAD="$(c++ -print-file-name=libasan.so):$(c++ -print-file-name=libubsan.so)"
export PYTHONPATH="$PWD/$pkg${PYTHONPATH:+:$PYTHONPATH}"
# Refuse to report success for a run that did not use the sanitized module.
"$py" -c "import liff._core as c, sys; sys.exit(0 if c.__file__.startswith('$PWD/$pkg/') else
          'sanitize: liff._core came from ' + c.__file__ + ', not the sanitized build')"
# shellcheck disable=SC2086  # PYTEST_ARGS is a list of words
"$py" -m pytest -q -p no:cacheprovider ${PYTEST_ARGS:-tests}
