"""The star tracker's shipped tables (the sky, the radiation grid): one small binary container, read bounded.

A table file is three parts: a first line naming the format, one line of
JSON (its provenance — the package, version and command that made it — and
its columns: name, dtype, shape), then the columns' little-endian bytes,
concatenated in that order and compressed with zlib. The tools in
``tools/`` write them (:func:`write_table`); the model reads them
(:func:`read_table`) with every size checked before it is read or
decompressed, and a missing, oversized or corrupt file is one line naming
the file and what is wrong — never a traceback.
"""

from __future__ import annotations

import hashlib
import json
import zlib
from importlib import resources
from pathlib import Path

import numpy as np

from ...storage.files import open_regular_file

#: First line of a table file.
MAGIC = b"# pmv_ros table 1\n"
#: Largest table file read, bytes (the sky is ≈ 0.5 MB, the radiation grid ≈ 1 MB).
MAX_TABLE_BYTES = 8 << 20
#: Largest decompressed payload, bytes.
MAX_PAYLOAD_BYTES = 64 << 20
#: Longest header line, bytes.
MAX_HEADER_BYTES = 64 << 10
#: The column types a table may hold.
DTYPES = ("<i2", "<i4", "<f4", "<f8", "|u1")


def data_path(name: str) -> Path:
    """The path of a file shipped in ``pmv_ros/data/``."""
    return Path(str(resources.files("pmv_ros") / "data" / name))


def write_table(path, provenance: dict, columns: dict) -> bytes:
    """Write ``columns`` (name → array, in order) with ``provenance`` to ``path``; returns the bytes written.

    The same arrays and provenance give the same bytes (zlib level 9, sorted JSON keys).
    """
    layout, payload = [], []
    for name, array in columns.items():
        array = np.asarray(array)
        dtype = array.dtype.newbyteorder("<") if array.dtype.byteorder not in "|<" else array.dtype
        if dtype.str not in DTYPES:
            raise ValueError(f"column {name}: dtype {array.dtype} is not one of {DTYPES}")
        layout.append({"name": name, "dtype": dtype.str, "shape": list(array.shape)})
        payload.append(np.ascontiguousarray(array, dtype=dtype).tobytes())
    raw = b"".join(payload)
    header = {"provenance": provenance, "columns": layout, "sha256": hashlib.sha256(raw).hexdigest()}
    data = MAGIC + json.dumps(header, sort_keys=True).encode() + b"\n" + zlib.compress(raw, 9)
    Path(path).write_bytes(data)
    return data


def read_table(path, what: str) -> tuple[dict, dict]:
    """(provenance, columns) of a table file; ValueError with one line naming the file if it cannot be used."""
    name = str(path)
    with open_regular_file(path, what, MAX_TABLE_BYTES) as stream:
        try:
            data = stream.read(MAX_TABLE_BYTES + 1)
        except OSError as error:
            raise ValueError(f"cannot read {what} {name}: {error.strerror or error}") from None
    return parse_table(data, name, what)


def parse_table(data: bytes, name: str, what: str) -> tuple[dict, dict]:
    """:func:`read_table` of bytes already read (``name`` for the messages)."""
    def refuse(problem: str) -> ValueError:
        return ValueError(f"{what} {name} is corrupt: {problem}")

    if not data.startswith(MAGIC):
        raise refuse("it does not start with the table format line")
    end = data.find(b"\n", len(MAGIC), len(MAGIC) + MAX_HEADER_BYTES)
    if end < 0:
        raise refuse("no header line")
    try:
        header = json.loads(data[len(MAGIC):end])
        layout = [(str(c["name"]), str(c["dtype"]), tuple(int(n) for n in c["shape"])) for c in header["columns"]]
        digest = str(header["sha256"])
        provenance = dict(header["provenance"])
    except (ValueError, KeyError, TypeError):
        raise refuse("its header is not the expected JSON") from None
    sizes = []
    for column, dtype, shape in layout:
        if dtype not in DTYPES or any(n < 0 for n in shape):
            raise refuse(f"column {column} has an unknown type or shape")
        sizes.append(int(np.prod(shape, dtype=np.int64)) * np.dtype(dtype).itemsize)
    total = sum(sizes)
    if total > MAX_PAYLOAD_BYTES:
        raise refuse(f"it declares {total} bytes of columns, more than the {MAX_PAYLOAD_BYTES} allowed")
    inflate = zlib.decompressobj()
    try:
        raw = inflate.decompress(data[end + 1:], total + 1)
    except zlib.error:
        raise refuse("its columns do not decompress") from None
    if len(raw) != total or not inflate.eof:
        raise refuse(f"its columns hold {len(raw)}{'+' if not inflate.eof else ''} bytes, not the {total} declared")
    if hashlib.sha256(raw).hexdigest() != digest:
        raise refuse("its columns do not match their checksum")
    columns, offset = {}, 0
    for (column, dtype, shape), size in zip(layout, sizes):
        columns[column] = np.frombuffer(raw, dtype, int(np.prod(shape, dtype=np.int64)), offset).reshape(shape)
        offset += size
    return provenance, columns
