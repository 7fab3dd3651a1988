"""Light field readers. Every reader returns an array (T, S, V, U[, C]) plus metadata.

So far: HCI 4D benchmark scene folders and PFM images (more formats: see the
project's issues).
"""

from .hci import HciScene, read_hci
from .pfm import read_pfm, write_pfm

__all__ = ["HciScene", "read_hci", "read_pfm", "write_pfm"]
