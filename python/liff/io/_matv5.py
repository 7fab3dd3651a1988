"""A guard in front of SciPy's MAT v5 reader, which is not hardened against damaged files.

``scipy.io.loadmat`` (1.17) looks up each data element's type code in a table of 20
dtypes without checking it first: codes 0, 8, 10, 11, 14, 15, 19 hit empty slots and
larger ones read past the table, and the interpreter crashes (fuzzing liff's reader found
it; scipy/scipy#25349 describes the same lookup; SciPy's documentation of ``loadmat``
says the reader is not hardened for untrusted input). So before SciPy sees a variable,
:func:`extract_variable` walks it the way SciPy will read it and checks every type code
on that path, then hands SciPy a file holding only that variable, so that SciPy reads
nothing that was not checked (no other variables, no subsystem data).

Format (MathWorks, "MAT-File Format", v5): a 128-byte header (text, subsystem data offset
at bytes 116-123, version 0x0100 and the endian indicator "IM" or "MI" at 124-127), then
data elements: a tag (type, byte count; a *small* element packs both into 4 bytes and
its data into the next 4) and the data padded to 8 bytes. A variable is an miMATRIX
element (14), or an miCOMPRESSED element (15) holding one zlib-compressed miMATRIX. An
miMATRIX holds array flags (class in the low byte, complex flag 0x800), dimensions,
a name, then per class: numeric arrays their real [and imaginary] data; char arrays one
data element; cells one miMATRIX per cell; structs a field-name length, the names, then
one miMATRIX per field per element.
"""

from __future__ import annotations

import io
import struct
import zlib
from typing import Optional, Tuple

#: data types SciPy can turn into a numeric array (miINT8 .. miUINT64; 8, 10, 11 are unused)
NUMERIC_TYPES = {1, 2, 3, 4, 5, 6, 7, 9, 12, 13}
#: data types SciPy decodes as characters (int8, uint8, uint16, UTF-8/16/32)
CHAR_TYPES = {1, 2, 4, 16, 17, 18}
MI_INT8, MI_INT32, MI_UINT32, MI_MATRIX, MI_COMPRESSED, MI_UTF8 = 1, 5, 6, 14, 15, 16
CELL, STRUCT, CHAR = 1, 2, 4
NUMERIC_CLASSES = set(range(6, 16))  # double, single, int8 .. uint64
CLASS_NAMES = {1: "cell", 2: "struct", 3: "object", 4: "char", 5: "sparse", 16: "function handle",
               17: "opaque object"}
#: nested arrays walked at most (a light field file's struct holds a few dozen)
MAX_ARRAYS = 100_000
#: dimensions of an array at most (SciPy's limit)
MAX_DIMS = 32
#: bytes of a struct's field names at most
MAX_NAMES = 1 << 20
CHUNK = 1 << 20


#: bytes per element SciPy allocates per MATLAB class (numeric classes; char arrays are
#: read as 4-byte characters, cells as object arrays of 8-byte references)
CLASS_BYTES = {6: 8, 7: 4, 8: 1, 9: 1, 10: 2, 11: 2, 12: 4, 13: 4, 14: 8, 15: 8, CHAR: 4, CELL: 8}


class Damaged(Exception):
    """The variable is not one this guard lets through; the message says why."""


class TooLarge(Exception):
    """Reading the variable would take more than the limit: at least ``claimed`` bytes."""

    def __init__(self, claimed: int):
        super().__init__(f"at least {claimed} bytes")
        self.claimed = claimed


class _Stream:
    """Sequential reads from raw bytes, or from a zlib stream inflated as it is read (in
    chunks, so that skipping a large array costs no memory)."""

    def __init__(self, data: bytes, compressed: bool):
        self.data, self.compressed = data, compressed
        self.inflater = zlib.decompressobj() if compressed else None
        self.buffer, self.offset = (b"", 0) if compressed else (data, 0)

    def _more(self, count: int) -> bool:
        """Inflates up to ``count`` more bytes into the buffer; False at the end."""
        if self.inflater is None:
            return False
        source = self.inflater.unconsumed_tail or self.data
        try:
            out = self.inflater.decompress(source, count)
        except zlib.error as e:
            raise Damaged(f"its compressed data is damaged ({e})") from None
        self.data = b""  # handed to the inflater; what it has not used is in unconsumed_tail
        if not out and len(self.inflater.unconsumed_tail) >= len(source):
            self.inflater = None
            return False
        self.buffer, self.offset = self.buffer[self.offset:] + out, 0
        return True

    def read(self, count: int) -> bytes:
        while len(self.buffer) - self.offset < count:
            if not self._more(max(count, CHUNK)):
                raise Damaged("it ends in the middle of an element")
        chunk = self.buffer[self.offset:self.offset + count]
        self.offset += count
        return chunk

    def skip(self, count: int) -> None:
        while len(self.buffer) - self.offset < count:
            count -= len(self.buffer) - self.offset
            self.buffer, self.offset = b"", 0
            if not self._more(min(count, CHUNK)):
                raise Damaged("it ends in the middle of an element")
        self.offset += count


class _Walker:
    """Reads a variable's elements in SciPy's order, checking each type code."""

    def __init__(self, stream: _Stream, order: str, limit: Optional[int] = None):
        self.stream, self.order, self.arrays = stream, order, 0
        self.limit, self.claimed = limit, 0

    def claim(self, count: int) -> None:
        """Counts ``count`` bytes SciPy will allocate; TooLarge past the limit."""
        self.claimed += count
        if self.limit is not None and self.claimed > self.limit:
            raise TooLarge(self.claimed)

    def tag(self) -> Tuple[int, int, Optional[bytes]]:
        """(type, byte count, data of a small element or None), as SciPy's cread_tag."""
        first, second = struct.unpack(self.order + "II", self.stream.read(8))
        if first >> 16:  # small data element
            if first >> 16 > 4:
                raise Damaged("a small data element claims more than 4 bytes")
            packed = struct.pack(self.order + "I", second)
            return first & 0xFFFF, first >> 16, packed[: first >> 16]
        return first, second, None

    def element(self, allowed, what: str, keep: int = 0) -> bytes:
        """Reads one data element of a type in ``allowed``; returns its data if ``keep``
        (at most that many bytes), else skips it."""
        kind, count, small = self.tag()
        if kind not in allowed:
            raise Damaged(f"{what} has data type {kind}; expected one of {sorted(allowed)}")
        if small is not None:
            return small
        if self.stream.compressed:  # SciPy holds the inflated variable beside its arrays
            self.claim(count)
        if keep:
            if count > keep:
                raise Damaged(f"{what} takes {count} bytes; expected at most {keep}")
            data = self.stream.read(count)
        else:
            self.stream.skip(count)
            data = b""
        if count % 8:
            self.stream.skip(8 - count % 8)
        return data

    def matrix(self) -> None:
        """One miMATRIX element and everything SciPy reads for it."""
        self.arrays += 1
        if self.arrays > MAX_ARRAYS:
            raise Damaged(f"it nests more than {MAX_ARRAYS} arrays")
        kind, count = struct.unpack(self.order + "II", self.stream.read(8))
        if kind != MI_MATRIX:
            raise Damaged(f"an array element has type {kind}; expected {MI_MATRIX} (miMATRIX)")
        if count == 0:  # an empty array
            return
        self.stream.skip(8)  # the flags' tag, which SciPy does not check
        flags, _ = struct.unpack(self.order + "II", self.stream.read(8))
        mclass, is_complex = flags & 0xFF, flags >> 11 & 1
        if mclass not in NUMERIC_CLASSES | {CELL, STRUCT, CHAR}:
            raise Damaged(f"it holds a MATLAB {CLASS_NAMES.get(mclass, f'class {mclass}')}, which "
                          f"liff does not read")
        dims = self.element({MI_INT32, MI_UINT32}, "the dimensions", keep=MAX_DIMS * 4)
        self.element({MI_INT8, MI_UTF8}, "the name")
        size = 1
        for d in struct.unpack(self.order + f"{len(dims) // 4}i", dims[: len(dims) // 4 * 4]):
            size *= max(d, 0)
        self.claim(size * CLASS_BYTES.get(mclass, 0) * (1 + is_complex))  # before any data
        if mclass in NUMERIC_CLASSES:
            for _ in range(1 + is_complex):
                self.element(NUMERIC_TYPES, "numeric data")
        elif mclass == CHAR:
            kind, count, small = self.tag()
            if count and kind not in CHAR_TYPES:
                raise Damaged(f"character data has data type {kind}; expected one of "
                              f"{sorted(CHAR_TYPES)}")
            if small is None:
                self.stream.skip(count + (8 - count % 8) % 8)
        elif mclass == CELL:
            for _ in range(size):
                self.matrix()
        else:  # a struct
            length = self.element({MI_INT32, MI_UINT32}, "the field name length", keep=8)
            if len(length) != 4 or struct.unpack(self.order + "i", length)[0] <= 0:
                raise Damaged("a struct's field name length is not one positive number")
            names = self.element({MI_INT8, MI_UTF8}, "the field names", keep=MAX_NAMES)
            for _ in range(size * (len(names) // struct.unpack(self.order + "i", length)[0])):
                self.matrix()


def _header_order(data: bytes) -> str:
    """The byte order ("<" or ">") of a MAT v5 file's header, which must be whole."""
    if len(data) < 128:
        raise Damaged("it is shorter than a MAT-file header")
    order = {b"IM": "<", b"MI": ">"}.get(data[126:128])
    if order is None or struct.unpack(order + "H", data[124:126])[0] != 0x0100:
        raise Damaged("its header is not a MAT v5 header (version 0x0100, IM or MI)")
    return order


def _variables(data: bytes, order: str):
    """(name, dims, class, start, end, stream) of each top-level variable of ``data``."""
    position = 128
    while position + 8 <= len(data):
        kind, count = struct.unpack(order + "II", data[position:position + 8])
        end = position + 8 + count
        if kind not in (MI_MATRIX, MI_COMPRESSED) or end > len(data):
            raise Damaged(f"the element at byte {position} is not a whole variable (type {kind}, "
                          f"{count} bytes)")
        if kind == MI_MATRIX:
            def stream(start=position, stop=end):
                return _Stream(data[start:stop], compressed=False)
        else:
            def stream(start=position + 8, stop=end):
                return _Stream(data[start:stop], compressed=True)
        name, dims, mclass = _header(stream(), order)
        yield name, dims, mclass, position, end, stream
        position = end


def _header(stream: _Stream, order: str):
    """(name, dims, class) of the variable whose miMATRIX element ``stream`` starts with."""
    walker = _Walker(stream, order)
    kind, count = struct.unpack(order + "II", stream.read(8))
    if kind != MI_MATRIX:
        raise Damaged(f"a variable has type {kind}; expected {MI_MATRIX} (miMATRIX)")
    if count == 0:
        return "", (), 0
    stream.skip(8)  # the flags' tag
    flags, _ = struct.unpack(order + "II", stream.read(8))
    if flags & 0xFF == 17:  # opaque objects have no dimensions
        return "", (), 17
    dims = walker.element({MI_INT32, MI_UINT32}, "the dimensions", keep=MAX_DIMS * 4)
    name = walker.element({MI_INT8, MI_UTF8}, "the name", keep=MAX_NAMES)
    return (name.decode("latin-1"), struct.unpack(order + f"{len(dims) // 4}i", dims[: len(dims) // 4 * 4]),
            flags & 0xFF)


def list_variables(data: bytes):
    """[(name, dims, MATLAB class number)] of the variables of the MAT v5 file ``data``.

    Raises
    ------
    Damaged
        If the header or a variable's header is damaged.
    """
    order = _header_order(data)
    return [(name, dims, mclass) for name, dims, mclass, *_ in _variables(data, order)]


def extract_variable(data: bytes, name: str, limit: Optional[int] = None) -> bytes:
    """A MAT v5 file holding only the variable ``name`` of the MAT v5 file ``data``, once
    every element SciPy will read of it has been checked.

    Parameters
    ----------
    limit : int, optional
        Bytes SciPy may allocate reading the variable (its arrays, as their dimensions
        state, and the inflated data of a compressed variable); counted as the walk
        goes, before any data is inflated past them.

    Raises
    ------
    Damaged
        With what is wrong: a damaged header or element, no variable ``name``, a type
        code SciPy would not survive, or a class other than numeric, char, cell, struct.
    TooLarge
        If the variable would take more than ``limit`` bytes.
    """
    order = _header_order(data)
    for found, _, _, start, end, stream in _variables(data, order):
        if found == name:
            _Walker(stream(), order, limit).matrix()
            return data[:116] + bytes(8) + data[124:128] + data[start:end]  # no subsystem data
    raise Damaged(f"no variable {name!r} found")


def loadmat_checked(scipy_io, data: bytes, name: str, limit: Optional[int] = None):
    """``scipy.io.loadmat`` of the variable ``name`` alone, after :func:`extract_variable`
    (which raises TooLarge past ``limit`` bytes)."""
    single = extract_variable(data, name, limit)
    return scipy_io.loadmat(io.BytesIO(single), variable_names=[name], squeeze_me=False,
                            struct_as_record=True, mat_dtype=False)[name]


#: bytes of a variable read (inflated) to get at its header: its dimensions, name and a
#: struct's field names
HEADER_BYTES = 1 << 16


def variable_headers(file) -> list:
    """[(name, dims, MATLAB class number, struct field names or ())] of the variables of
    the open MAT v5 file ``file``, from their headers alone: at most :data:`HEADER_BYTES`
    of each variable are read (inflated), the rest skipped by seeking.

    Raises
    ------
    Damaged
        If the file's header or a variable's header is damaged or cut short.
    """
    order = _header_order(file.read(128))
    file.seek(0, io.SEEK_END)
    size = file.tell()
    position, found = 128, []
    while position + 8 <= size:
        file.seek(position)
        kind, count = struct.unpack(order + "II", file.read(8))
        end = position + 8 + count
        if kind not in (MI_MATRIX, MI_COMPRESSED) or end > size:
            raise Damaged(f"the element at byte {position} is not a whole variable (type {kind}, "
                          f"{count} bytes)")
        if kind == MI_MATRIX:
            head = struct.pack(order + "II", kind, count) + file.read(min(count, HEADER_BYTES))
        else:
            inflater, head, left = zlib.decompressobj(), b"", count
            while len(head) < HEADER_BYTES and left > 0 and not inflater.eof:
                piece = file.read(min(left, 1 << 14))
                left -= len(piece)
                try:
                    head += inflater.decompress(piece, HEADER_BYTES - len(head))
                except zlib.error as e:
                    raise Damaged(f"its compressed data is damaged ({e})") from None
        stream = _Stream(head, compressed=False)
        name, dims, mclass = _header(stream, order)
        fields: tuple = ()
        if mclass == STRUCT:
            walker = _Walker(stream, order)
            length = walker.element({MI_INT32, MI_UINT32}, "the field name length", keep=8)
            width = struct.unpack(order + "i", length[:4])[0] if len(length) >= 4 else 0
            if width <= 0:
                raise Damaged("a struct's field name length is not one positive number")
            names = walker.element({MI_INT8, MI_UTF8}, "the field names", keep=MAX_NAMES)
            fields = tuple(names[i:i + width].split(b"\0", 1)[0].decode("latin-1")
                           for i in range(0, len(names) - width + 1, width))
        found.append((name, dims, mclass, fields))
        position = end
    return found
