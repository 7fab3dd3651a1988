"""The command line's names for what the library names in Python: a reader option's
flag (``keep`` -> ``--keep-views``, from the format registry, liff.io.formats), a
detector parameter's (``contrastThreshold`` -> ``--contrast-threshold``, from
liff.PARAMETERS), and messages with those names put in, so that a batch run's manifest
and the command line's errors read alike. The reader options are argparse options here
too: a list file's lines (``--from-list``, :mod:`liff._inputs`) parse them as the
command line does.

Layer: the detector's (it reads liff.PARAMETERS); the batch runs and the command line
use it (tests/test_layers.py).
"""

from __future__ import annotations

import argparse
import re
from typing import Dict

from ._detector import PARAMETERS
from .io.formats import FORMATS, OPTIONS, flag_help, format_help


def add_reader_options(parser: argparse.ArgumentParser) -> None:
    """``--format``, one flag per reader option and ``--preprocess``, from the format
    registry (liff.io.formats: choices, help and the formats each option applies to)."""
    group = parser.add_argument_group("reading light fields (docs/INPUTS.md)")
    group.add_argument("--format", default=None, choices=list(FORMATS), metavar="FORMAT",
                       help=format_help())
    for option in OPTIONS.values():
        group.add_argument(option.flag, dest=reader_dest(option.flag), type=option.type,
                           nargs=option.nargs, metavar=option.metavar, default=None,
                           help=flag_help(option))
    group.add_argument("--preprocess", action="store_true", help=PREPROCESS_HELP)


#: what liff.preprocess.prepare does, as the README says it (tests/io/test_format_registry.py)
PREPROCESSING = "luminance, gamma 0.5, one histogram stretch over the whole light field"


#: --preprocess's help
PREPROCESS_HELP = f"the paper's SfM preprocessing: {PREPROCESSING} (off unless asked for)"


def reader_dest(flag: str) -> str:
    """The attribute argparse keeps a flag's value in: ``--keep-views`` -> ``keep_views``."""
    return flag[2:].replace("-", "_")


def reader_options(args: argparse.Namespace) -> dict:
    """Keyword arguments for liff.io.read_light_field from the parsed options (those
    given: the format and each reader option of the registry)."""
    options = {"format": args.format} if getattr(args, "format", None) else {}
    for option in OPTIONS.values():
        given = getattr(args, reader_dest(option.flag), None)
        if given is not None:
            options[option.keyword] = option.value(given)
    return options


def option_name(parameter: str) -> str:
    """The command-line flag of a create() keyword: ``contrastThreshold`` ->
    ``--contrast-threshold``, ``nOctaveLayers`` -> ``--n-octave-layers``."""
    return "--" + re.sub(r"(?<!^)(?=[A-Z])", "-", parameter).lower()


def keyword_flags() -> Dict[str, str]:
    """Python keyword -> command-line flag for the reader options (from the format
    registry, ``keep`` -> ``--keep-views``) and detector parameters
    (``contrastThreshold`` -> ``--contrast-threshold``)."""
    flags = {p.name: option_name(p.name) for p in PARAMETERS}
    flags.update({o.keyword: o.flag for o in OPTIONS.values()})
    return flags


def name_flags(message: str) -> str:
    """``message`` with the readers' and the detector's Python keywords named as the
    command line's flags: "keep = 20" -> "--keep-views = 20", "(n=N)" -> "(--lenslet N)",
    "format='mosaic'" -> "--format mosaic",
    "option(s) key do not apply ...; expected n, keep" -> "option(s) --key ...; expected
    --lenslet, --keep-views"."""
    flags = keyword_flags()

    def in_list(match: re.Match) -> str:
        return re.sub(r"(?<![\w-])\w+", lambda word: OPTIONS[word.group(0)].flag
                      if word.group(0) in OPTIONS else word.group(0), match.group(0))

    # format='mosaic' (the Python keyword): --format mosaic, once where both are named
    message = re.sub(r"format='(\w+)', --format \1\b", r"--format \1", message)
    message = re.sub(r"(?<![\w.-])format='(\w+)'", r"--format \1", message)
    if " do not apply to format " in message:  # liff.io.read_light_field's option check
        message = re.sub(r"(?<=option\(s\) ).*", in_list, message, flags=re.S)
    for option in OPTIONS.values():  # "n=N" as the command line writes it: "--lenslet N"
        message = re.sub(rf"(?<![\w.-]){option.keyword}=(?=\S)", option.flag + " ", message)
    for keyword, flag in flags.items():
        camel = keyword != keyword.lower()  # detector parameters: unique words, named anywhere
        pattern = rf"(?<![\w.-]){keyword}\b" + ("" if camel else r"(?= ?[=<>]| \(| \d)")
        message = re.sub(pattern, flag, message)
    # "read it with bit_depth=8 (--bit-depth 8)" has become "--bit-depth 8 (--bit-depth 8)",
    # and "--overwrite (overwrite=True)" is the API's name beside the flag: the flag once
    message = re.sub(r"(--[\w-]+(?: [^\s()]+)?) \(\1\)", r"\1", message)
    message = re.sub(r"(--[\w-]+) \((\w+)=True\)",
                     lambda m: m.group(1) if m.group(2).replace("_", "-") == m.group(1)[2:]
                     else m.group(0), message)
    return message


def shown_options(options: dict) -> str:
    """Reader options as the command line writes them: ``--lenslet 14 --keep-views 11``
    (the format left out)."""
    return " ".join(OPTIONS[k].shown(v) for k, v in options.items() if k in OPTIONS)


def error_line(command: str, name: str, error: str) -> str:
    """``liff <command>: <name>: <error>``, naming the input once: readers' messages
    already start with its path."""
    text = name_flags(error)
    return f"liff {command}: " + (text if text.startswith(name) else f"{name}: {text}")
