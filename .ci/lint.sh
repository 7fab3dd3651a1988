#!/usr/bin/env bash
# ruff (pyproject.toml's [tool.ruff]: pycodestyle, pyflakes, import order) over the
# package, tests, benchmarks, samples and fuzz targets, and mypy ([tool.mypy]) over the
# package, with the versions pinned here; run by .ci/run after set-up.
set -euo pipefail
cd "$(dirname "$0")/.."
.venv/bin/python -m pip install -q --disable-pip-version-check "ruff==0.17.6" "mypy==2.4.1"
.venv/bin/ruff check python/liff tests benchmarks samples fuzz
.venv/bin/mypy
