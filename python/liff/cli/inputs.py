"""The inputs of a command: :mod:`liff._inputs` (the batch runs' layer, where
:func:`liff.batch.detect` expands its inputs too), named here as the command line had
them."""

from .._inputs import Input, describe, expand, list_line_parser, read_list, resolve_options  # noqa: F401
