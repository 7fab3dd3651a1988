#!/usr/bin/env bash
# One-command set-up for a fresh Debian/Ubuntu machine, used by the README and by CI:
# installs what is missing (the system OpenCV dev package, a C++ compiler, venv and,
# for `test`, GoogleTest), makes a virtualenv in .venv, installs liff into it, then
#   demo [DIR]  runs the main job on the built-in example (pictures into DIR), or
#   test        builds and runs the C++ tests (GoogleTest) and sample (against the
#               installed C++ package), then runs the Python test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:-demo}
case "$mode" in demo|test) ;; *) echo "usage: $0 demo [DIR] | test" >&2; exit 2 ;; esac

missing=()
dpkg -s libopencv-dev >/dev/null 2>&1 || missing+=(libopencv-dev)
if [ "$mode" = test ]; then  # the C++ tests (CMake's find_package(GTest))
  dpkg -s libgtest-dev >/dev/null 2>&1 || missing+=(libgtest-dev)
fi
command -v c++ >/dev/null 2>&1 || missing+=(g++)
python3 -c 'import venv, ensurepip' >/dev/null 2>&1 || missing+=(python3-venv)
if [ ${#missing[@]} -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo=sudo
  echo "liff setup: installing ${missing[*]} with apt-get"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if [ ! -x .venv/bin/python ]; then
  echo "liff setup: making a virtualenv in .venv"
  python3 -m venv .venv
fi
# pip builds the C++ core (CMake, scikit-build-core) quietly: say what takes the time.
echo "liff setup: installing liff and its dependencies into .venv; this builds the C++ core (1-2 min on 2 cores)"
start=$SECONDS
.venv/bin/python -m pip install -q --disable-pip-version-check ".[test]"
echo "liff setup: installed in $((SECONDS - start)) s"

if [ "$mode" = demo ]; then
  echo "liff setup: running liff demo --out ${2:-liff-demo}"
  exec .venv/bin/liff demo --out "${2:-liff-demo}"
fi

echo "liff setup: building and running the C++ tests and sample"

bash .ci/cpp_sample.sh
echo "liff setup: running the Python tests"
.venv/bin/python -m pytest tests
