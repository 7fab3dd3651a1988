#!/usr/bin/env bash
# C++ side: builds the library with its tests (cpp/tests, GoogleTest: needs libgtest-dev)
# and runs them with ctest, installs the library, then builds and runs samples/cpp
# against the installed package with find_package(liff).
# Uses .venv's cmake/ninja (from PyPI).
set -euo pipefail
cd "$(dirname "$0")/.."
.venv/bin/python -m pip install -q --disable-pip-version-check cmake ninja
export PATH="$PWD/.venv/bin:$PATH"
prefix="$PWD/build/cpp-install"
rm -rf build/cpp build/cpp-sample "$prefix"
cmake -S . -B build/cpp -G Ninja -DCMAKE_BUILD_TYPE=Release -DLIFF_BUILD_TESTS=ON >/dev/null
cmake --build build/cpp
ctest --test-dir build/cpp --output-on-failure
cmake --install build/cpp --prefix "$prefix" >/dev/null
cmake -S samples/cpp -B build/cpp-sample -G Ninja -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build build/cpp-sample
./build/cpp-sample/detect_features
