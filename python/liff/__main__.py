"""``python -m liff``: the ``liff`` command."""

import sys

from .cli import main

sys.exit(main())
