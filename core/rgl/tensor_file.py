"""Mitsuba's *tensor file*, the container of RGL ``.bsdf`` materials: named n-dimensional arrays.

Layout (little endian): the 12 bytes ``b"tensor_file\\0"``, a version ``(major, minor) = (1, 0)`` as two
uint8, a uint32 field count; then per field its name (uint16 length + UTF-8 bytes), its rank (uint16), its
type code (uint8: 1 uint8, 2 int8, 3 uint16, 4 int16, 5 uint32, 6 int32, 7 uint64, 8 int64, 9 float16,
10 float32, 11 float64), the byte offset of its data (uint64) and its shape (rank x uint64). The data of each
field follows the headers, C order, at the given offset (the writer aligns offsets to 8 bytes).

Reading checks every header against the file's size and names the field and the problem in a
:class:`~core.errors.FileFormatError`; nothing here knows what the fields mean (see :mod:`core.rgl.material`).
"""

from __future__ import annotations

import os
import struct
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from core.errors import FileFormatError
from core.io import atomic_write, check_input_file, read_bounded

MAGIC = b"tensor_file\0"
VERSION = (1, 0)
DTYPES: dict[int, np.dtype] = {
    1: np.dtype("u1"),
    2: np.dtype("i1"),
    3: np.dtype("<u2"),
    4: np.dtype("<i2"),
    5: np.dtype("<u4"),
    6: np.dtype("<i4"),
    7: np.dtype("<u8"),
    8: np.dtype("<i8"),
    9: np.dtype("<f2"),
    10: np.dtype("<f4"),
    11: np.dtype("<f8"),
}
CODES = {dt: code for code, dt in DTYPES.items()}
ALIGN = 8
MAX_BYTES = 1 << 30
"""The largest tensor file read (the RGL database's anisotropic materials are tens of megabytes)."""


def read_tensor_file(path: str | os.PathLike[str], what: str = "tensor file") -> dict[str, np.ndarray]:
    """Every field of the file at ``path``, by name (arrays in their stored type and shape)."""
    p = Path(path)
    where = f"{what} '{p}'"
    check_input_file(p, where)
    try:
        data = read_bounded(p, MAX_BYTES, what)
    except OSError as exc:
        raise FileFormatError(f"{where} cannot be read: {exc.strerror or exc}") from None
    size = len(data)
    if size < len(MAGIC) + 2 + 4:
        raise FileFormatError(f"{where} is truncated: {size} bytes, too short for a tensor-file header")
    if data[: len(MAGIC)] != MAGIC:
        raise FileFormatError(f"{where} is not a tensor file (it does not start with 'tensor_file')")
    version = tuple(data[12:14])
    if version != VERSION:
        raise FileFormatError(f"{where} has tensor-file version {version[0]}.{version[1]}; expected 1.0")
    (count,) = struct.unpack_from("<I", data, 14)
    pos = 18
    fields: dict[str, np.ndarray] = {}

    def need(n: int, what_part: str) -> None:
        if pos + n > size:
            raise FileFormatError(f"{where} is truncated: it ends inside the header of {what_part}")

    for index in range(count):
        need(2, f"field {index + 1} of {count}")
        (name_len,) = struct.unpack_from("<H", data, pos)
        pos += 2
        need(name_len + 2 + 1 + 8, f"field {index + 1} of {count}")
        try:
            name = data[pos : pos + name_len].decode("utf-8")
        except UnicodeDecodeError:
            raise FileFormatError(f"{where}: field {index + 1} has a name that is not UTF-8") from None
        pos += name_len
        ndim, code, offset = struct.unpack_from("<HBQ", data, pos)
        pos += 11
        if code not in DTYPES:
            raise FileFormatError(f"{where}: field '{name}' has unknown type code {code}")
        need(8 * ndim, f"field '{name}'")
        shape = struct.unpack_from(f"<{ndim}Q", data, pos)
        pos += 8 * ndim
        dtype = DTYPES[code]
        count_values = int(np.prod(shape, dtype=np.int64)) if ndim else 1
        end = offset + count_values * dtype.itemsize
        if end > size:
            raise FileFormatError(
                f"{where} is truncated: field '{name}' (shape {tuple(shape)}) needs bytes {offset}-{end}, "
                f"the file has {size}"
            )
        if name in fields:
            raise FileFormatError(f"{where} holds field '{name}' twice")
        fields[name] = (
            np.frombuffer(data, dtype=dtype, count=count_values, offset=offset).reshape(shape).copy()
        )
    return fields


def write_tensor_file(path: str | os.PathLike[str], fields: Mapping[str, np.ndarray | str]) -> None:
    """Write ``fields`` (arrays, or strings stored as uint8) as a tensor file, atomically."""
    arrays: list[tuple[bytes, np.ndarray]] = []
    for name, value in fields.items():
        if isinstance(value, str):
            arr = np.frombuffer(value.encode("utf-8"), dtype=np.uint8)
        else:
            arr = np.ascontiguousarray(value)
        dt = arr.dtype if arr.dtype.byteorder == "|" else arr.dtype.newbyteorder("<")
        if dt not in CODES:
            raise FileFormatError(f"cannot store field '{name}' of type {arr.dtype} in a tensor file")
        arrays.append((name.encode("utf-8"), arr.astype(dt, copy=False)))
    header = bytearray(MAGIC + bytes(VERSION) + struct.pack("<I", len(arrays)))
    header_len = len(header) + sum(2 + len(n) + 2 + 1 + 8 + 8 * a.ndim for n, a in arrays)
    offsets = []
    pos = header_len
    for _, arr in arrays:
        pos = (pos + ALIGN - 1) // ALIGN * ALIGN
        offsets.append(pos)
        pos += arr.nbytes
    for (name, arr), offset in zip(arrays, offsets, strict=True):
        header += struct.pack("<H", len(name)) + name
        header += struct.pack("<HBQ", arr.ndim, CODES[arr.dtype], offset)
        header += struct.pack(f"<{arr.ndim}Q", *arr.shape)
    with atomic_write(path, "wb") as fh:
        fh.write(bytes(header))
        written = len(header)
        for (_, arr), offset in zip(arrays, offsets, strict=True):
            fh.write(b"\0" * (offset - written))
            fh.write(arr.tobytes())
            written = offset + arr.nbytes
