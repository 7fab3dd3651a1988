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

[ -x .venv/bin/python ] || python3 -m venv .venv
.venv/bin/python -m pip install -q --disable-pip-version-check ".[test]"

if [ "$mode" = demo ]; then
  exec .venv/bin/liff demo --out "${2:-liff-demo}"
fi

bash .ci/cpp_sample.sh
.venv/bin/python -m pytest tests
