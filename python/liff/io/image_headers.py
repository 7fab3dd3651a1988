"""The size an image will decode to, from its header alone (nothing is inflated).

OpenCV offers no way to read an image's size without decoding it, and a compressed
image of a few MB can decode to GBs. :func:`decoded_size` reads the header of the
formats liff reads views and lenslet images from (PNG, JPEG, TIFF, BMP, PNM, WebP),
told by their first bytes as OpenCV tells them, so that readers can check the size
against the memory budget (:mod:`liff._budget`) before decoding. The channel count is
an upper bound of what ``cv2.IMREAD_UNCHANGED`` returns (a palette PNG may become BGR
or BGRA: 4 is counted; grey + alpha becomes BGRA: 4).
"""

from __future__ import annotations

import re
import struct
from typing import BinaryIO, Callable, Dict, NamedTuple, Optional

from .._paths import special_kind

#: header bytes read (a JPEG's frame header may follow up to 64 KB of EXIF data; a TIFF's
#: first directory, often written after the pixels, is read where it is)
HEADER_BYTES = 1 << 17


class DecodedSize(NamedTuple):
    """What an image decodes to: rows, columns, channels (at most) and bytes per sample."""

    height: int
    width: int
    channels: int
    itemsize: int

    @property
    def nbytes(self) -> int:
        return self.height * self.width * self.channels * self.itemsize

    def describe(self) -> str:
        return (f"an image of {self.width}x{self.height} with up to {self.channels} "
                f"channel(s) of {8 * self.itemsize} bits")


PNG_CHANNELS = {0: 1, 2: 3, 3: 4, 4: 4, 6: 4}  # colour type -> channels OpenCV returns


def _png(head: bytes, file: BinaryIO) -> Optional[DecodedSize]:
    if len(head) < 26 or head[12:16] != b"IHDR":
        return None
    width, height, depth, colour = struct.unpack(">IIBB", head[16:26])
    return DecodedSize(height, width, PNG_CHANNELS.get(colour, 4), 2 if depth == 16 else 1)


def _jpeg(head: bytes, file: BinaryIO) -> Optional[DecodedSize]:
    position = 2
    while position + 4 <= len(head):
        if head[position] != 0xFF:
            return None
        marker = head[position + 1]
        if marker == 0xFF:  # fill byte
            position += 1
            continue
        if marker in (0x01, *range(0xD0, 0xD8)):  # markers without a length
            position += 2
            continue
        length = struct.unpack(">H", head[position + 2:position + 4])[0]
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):  # a start of frame
            if position + 10 > len(head):
                return None
            precision, height, width, components = struct.unpack(
                ">BHHB", head[position + 4:position + 10])
            channels = components if components in (1, 3) else 4  # CMYK: BGR, counted 4
            return DecodedSize(height, width, channels, 2 if precision > 8 else 1)
        position += 2 + length
    return None


TIFF_TYPES = {3: ("H", 2), 4: ("I", 4)}  # SHORT, LONG


def _tiff(head: bytes, file: BinaryIO) -> Optional[DecodedSize]:
    order = "<" if head[:2] == b"II" else ">"
    if len(head) < 8 or struct.unpack(order + "H", head[2:4])[0] != 42:
        return None  # BigTIFF (43) and others: not read here
    file.seek(struct.unpack(order + "I", head[4:8])[0])
    count = struct.unpack(order + "H", file.read(2))[0]
    directory = file.read(12 * count)
    tags: Dict[int, int] = {}  # tag -> its first value
    for index in range(count):
        entry = directory[12 * index:12 * index + 12]
        if len(entry) < 12:
            return None
        tag, kind, values = struct.unpack(order + "HHI", entry[:8])
        if kind in TIFF_TYPES:
            code, size = TIFF_TYPES[kind]
            field = entry[8:8 + size]
            if values * size > 4:  # the values lie elsewhere (BitsPerSample of colour)
                file.seek(struct.unpack(order + "I", entry[8:12])[0])
                field = file.read(size)
            tags[tag] = struct.unpack(order + code, field)[0]
    if 256 not in tags or 257 not in tags:
        return None
    itemsize = max(1, (min(tags.get(258, 8), 64) + 7) // 8)
    samples = tags.get(277, 1)
    return DecodedSize(tags[257], tags[256], samples if samples in (1, 3) else max(4, samples),
                       itemsize)


def _bmp(head: bytes, file: BinaryIO) -> Optional[DecodedSize]:
    if len(head) < 30:
        return None
    width, height, _, bits = struct.unpack("<iiHH", head[18:30])
    return DecodedSize(abs(height), abs(width), 4 if bits == 32 else 3, 1)


PNM_HEADER = re.compile(rb"P([1-6])((?:\s+|#[^\n]*\n)+)(\d+)\s+(?:#[^\n]*\n\s*)*(\d+)"
                        rb"(?:\s+(?:#[^\n]*\n\s*)*(\d+))?")


def _pnm(head: bytes, file: BinaryIO) -> Optional[DecodedSize]:
    match = PNM_HEADER.match(head)
    if match is None:
        return None
    kind, width, height = int(match.group(1)), int(match.group(3)), int(match.group(4))
    maxval = int(match.group(5)) if match.group(5) and kind not in (1, 4) else 1
    return DecodedSize(height, width, 3 if kind in (3, 6) else 1, 2 if maxval > 255 else 1)


def _webp(head: bytes, file: BinaryIO) -> Optional[DecodedSize]:
    chunk = head[12:16]
    if chunk == b"VP8X" and len(head) >= 30:
        width = int.from_bytes(head[24:27], "little") + 1
        height = int.from_bytes(head[27:30], "little") + 1
        return DecodedSize(height, width, 4, 1)
    if chunk == b"VP8L" and len(head) >= 25:
        bits = int.from_bytes(head[21:25], "little")
        return DecodedSize((bits >> 14 & 0x3FFF) + 1, (bits & 0x3FFF) + 1, 4, 1)
    if chunk == b"VP8 " and len(head) >= 30:
        width, height = struct.unpack("<HH", head[26:30])
        return DecodedSize(height & 0x3FFF, width & 0x3FFF, 4, 1)
    return None


#: (first bytes, header reader), as OpenCV tells the formats apart
FORMATS: tuple = (
    (b"\x89PNG\r\n\x1a\n", _png), (b"\xff\xd8", _jpeg), (b"II*\x00", _tiff),
    (b"MM\x00*", _tiff), (b"BM", _bmp), (b"P", _pnm), (b"RIFF", _webp))


def decoded_size(path: str) -> Optional[DecodedSize]:
    """What ``cv2.imread(path, cv2.IMREAD_UNCHANGED)`` will allocate, from the header;
    None for a format not read here, a header that cannot be read (OpenCV then
    decides, within its own pixel limit), or a path that is not a regular file (never
    opened: the reader refuses it)."""
    if special_kind(path) is not None:  # opening a FIFO would block
        return None
    try:
        with open(path, "rb") as f:
            head = f.read(HEADER_BYTES)
            reader: Optional[Callable[[bytes, BinaryIO], Optional[DecodedSize]]] = next(
                (read for magic, read in FORMATS if head.startswith(magic)), None)
            if reader is None or (reader is _webp and head[8:12] != b"WEBP"):
                return None
            return reader(head, f)
    except (OSError, ValueError, struct.error):  # unreadable, a bad offset, a header cut short
        return None
