"""One registry of input formats (liff.io.formats): every reader module is registered,
and the command line, docs/INPUTS.md and the fuzz targets are derived from it."""

from __future__ import annotations

import argparse
import importlib
import inspect
import os
import pkgutil
import sys
import types

import pytest

import liff.io
from liff.cli import build_parser
from liff.io import LightFieldFile
from liff.io.formats import FORMATS, OPTIONS, formats_table

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def reader_functions(module: types.ModuleType) -> list:
    """The public ``read_*`` functions a module defines that return a LightFieldFile."""
    return [f for name, f in vars(module).items()
            if name.startswith("read_") and inspect.isfunction(f) and f.__module__ == module.__name__
            and inspect.signature(f).return_annotation in ("LightFieldFile", LightFieldFile)]


def unregistered_readers(modules) -> list:
    """``module.function`` of each light field reader that no registry entry reads with."""
    registered = {f.read for f in FORMATS.values()}
    return [f"{m.__name__}.{f.__name__}" for m in modules for f in reader_functions(m)
            if f not in registered]


def io_modules() -> list:
    """liff.io's public modules but ``read`` (read_light_field, which dispatches)."""
    return [importlib.import_module(f"liff.io.{info.name}")
            for info in pkgutil.iter_modules(liff.io.__path__)
            if not info.name.startswith("_") and info.name != "read"]


def test_every_reader_module_is_registered():
    modules = io_modules()
    assert sum(len(reader_functions(m)) for m in modules) >= len(FORMATS) - 1  # (npy, npz: one)
    assert unregistered_readers(modules) == []


def test_a_reader_module_without_an_entry_is_caught():
    module = types.ModuleType("liff.io.lytro_raw")

    def read_lytro_raw(path) -> LightFieldFile:
        raise NotImplementedError

    read_lytro_raw.__module__ = module.__name__
    module.read_lytro_raw = read_lytro_raw
    assert unregistered_readers(io_modules() + [module]) == ["liff.io.lytro_raw.read_lytro_raw"]


@pytest.mark.parametrize("name", sorted(FORMATS))
def test_each_entry_names_options_its_reader_takes(name):
    fmt = FORMATS[name]
    parameters = inspect.signature(fmt.read).parameters
    assert set(fmt.options) <= set(parameters) and set(fmt.options) <= set(OPTIONS), name
    assert fmt.what and (fmt.names or name == "mosaic")


def test_docs_list_the_registry():
    with open(os.path.join(ROOT, "docs", "INPUTS.md"), encoding="utf-8") as f:
        text = f.read()
    shown = text.split("<!-- formats_table -->\n")[1].split("<!-- /formats_table -->")[0]
    assert shown.strip() == formats_table()
    for name in FORMATS:  # each format has its section
        assert f"(`{name}`" in text or f"`{name}`)" in text, name


def reader_group(command: str) -> dict:
    parser = next(a for a in build_parser()._actions
                  if isinstance(a, argparse._SubParsersAction)).choices[command]
    return {flag: action for action in parser._actions for flag in action.option_strings}


@pytest.mark.parametrize("command", ["detect", "match", "pose", "colmap", "sfm"])
def test_the_command_line_offers_the_registry(command):
    actions = reader_group(command)
    assert list(actions["--format"].choices) == list(FORMATS)
    for name, fmt in FORMATS.items():
        assert name + ":" in actions["--format"].help
    for option in OPTIONS.values():
        help_text = actions[option.flag].help
        takers = [n for n, f in FORMATS.items() if option.keyword in f.takes()]
        assert takers and (all(n in help_text for n in takers) if len(takers) < len(FORMATS)
                           else "every format" in help_text), option.flag


def test_the_fuzz_targets_cover_every_format():
    sys.path.insert(0, os.path.join(ROOT, "fuzz"))
    try:
        readers = importlib.import_module("readers")
    finally:
        sys.path.pop(0)
    fuzzed = {r.name for r in readers.READERS}
    for name, fmt in FORMATS.items():
        assert fmt.fuzz is not None and name in fuzzed, name
        assert os.path.isdir(os.path.join(ROOT, "fuzz", "corpus", name)), name


def readme() -> str:
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        return " ".join(f.read().split())  # lines joined


@pytest.mark.parametrize("command", ["detect", "pose", "colmap", "sfm"])
def test_help_texts_say_what_the_readme_says(command):
    """Issue 31 item 6: --preprocess said histogram equalisation (the README: one
    histogram stretch), --last-slope's help said =-inf."""
    from liff.cli.common import PREPROCESSING

    actions = reader_group(command)
    assert "(luminance, gamma 0.5, one histogram stretch over the whole light field)" in readme()
    assert PREPROCESSING in actions["--preprocess"].help and PREPROCESSING in readme()
    assert "equalisation" not in actions["--preprocess"].help
    # the slope range's ends: the README's create() defaults, and the flags' help
    assert "firstSlope=-inf, lastSlope=+inf" in readme()
    assert actions["--first-slope"].help.endswith("--first-slope=-inf")
    assert actions["--last-slope"].help.endswith("--last-slope=inf")
