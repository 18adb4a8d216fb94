"""CSV written for machines and spreadsheets: a header with units, full float precision, atomic.

Floats are written as the shortest text that reads back to the same float64 (what Python's
``repr`` guarantees), so pandas/numpy read the exact values back, in Apache Arrow's notation
(double-conversion's shortest mode: decimal for decimal exponents -6 to 9, else ``1.5e+10``,
``2e-7``); an integral value gets a trailing ``.0`` as ``repr`` writes it, so every float column
still reads back as float64. Large tables are formatted by Arrow's float-to-string cast, in C++
and by blocks of rows (about 4× faster than Python's csv module); up to :data:`SMALL_VALUES`
fields the same text is made from ``repr`` in Python, which costs less than importing Arrow's
compute module (0.1 s of a command's start-up). Other columns are written as Python's csv module
would (quoted only when needed). A NaN or infinite value is refused before anything is written:
fuzzyfeed never exports a feed it could not compute.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np

from fuzzyfeed.errors import ExportError
from fuzzyfeed.base.atomic import atomic_write


def write_columns(path: str | os.PathLike, columns: Mapping[str, np.ndarray],
                  allow_nan: tuple[str, ...] = ()) -> None:
    """Write equal-length columns to ``path`` (header = the keys), atomically."""
    if not isinstance(columns, Mapping) or not columns:
        raise ExportError(f"{path}: columns: {type(columns).__name__}; expected a non-empty mapping "
                          "name -> array")
    names = list(columns)
    arrays = [np.asarray(columns[n]) for n in names]
    lengths = {a.shape[0] for a in arrays}
    if len(lengths) != 1:
        raise ExportError(f"{path}: columns have different lengths {sorted(lengths)}")
    for name, arr in zip(names, arrays):
        if arr.dtype.kind == "f" and name not in allow_nan and not np.isfinite(arr).all():
            i = int(np.argmax(~np.isfinite(arr)))
            raise ExportError(f"{path}: column {name} row {i} = {arr[i]}; refusing to write a "
                              "non-finite value")
    with atomic_write(path, "w", newline="") as handle:
        handle.write(",".join(_quote(n) for n in names) + "\n")
        _write_rows(handle, arrays)


class ColumnStream:
    """Rows written as they come: :meth:`write` takes equal-length columns (the same names every
    time), refuses a non-finite float before writing any of its rows, and writes the header with
    the first. Text identical to :func:`write_columns` of the columns end to end."""

    def __init__(self, handle, path: str | os.PathLike):
        self.handle, self.path, self.names, self.rows = handle, path, None, 0

    def write(self, columns: Mapping[str, np.ndarray]) -> None:
        names = list(columns)
        if self.names is None:
            self.names = names
            self.handle.write(",".join(_quote(n) for n in names) + "\n")
        elif names != self.names:
            raise ExportError(f"{self.path}: columns {names} after {self.names}")
        arrays = [np.asarray(columns[n]) for n in names]
        if len({a.shape[0] for a in arrays}) != 1:
            raise ExportError(f"{self.path}: columns have different lengths")
        for name, arr in zip(names, arrays):
            if arr.dtype.kind == "f" and not np.isfinite(arr).all():
                i = int(np.argmax(~np.isfinite(arr)))
                raise ExportError(f"{self.path}: column {name} row {self.rows + i} = {arr[i]}; refusing "
                                  "to write a non-finite value")
        _write_rows(self.handle, arrays)
        self.rows += arrays[0].shape[0]


#: Rows formatted per block (bounds the memory of the text: ~15 MB for 11 float columns).
ROWS_PER_BLOCK = 1 << 16

#: Tables of at most this many fields (rows × columns) are formatted in Python, larger ones by Arrow.
SMALL_VALUES = 1 << 16


def _quote(text: str) -> str:
    """A field as Python's csv module writes it (quoted only when it holds , " or a line break)."""
    if any(c in text for c in ',"\r\n'):
        return '"' + text.replace('"', '""') + '"'
    return text


def _strings(lengths: np.ndarray, data: bytes):
    """An Arrow string array from its field lengths and concatenated UTF-8 bytes.

    Arrays are built from buffers throughout: ``pa.array``/``pa.scalar`` would import pandas
    (0.3 s) to check for pandas objects."""
    import pyarrow as pa

    offsets = np.zeros(lengths.size + 1, dtype=np.int32)
    np.cumsum(lengths, out=offsets[1:])
    return pa.Array.from_buffers(pa.string(), lengths.size,
                                 [None, pa.py_buffer(offsets), pa.py_buffer(data)])


def _constant(text: str, n: int):
    return _strings(np.full(n, len(text.encode())), text.encode() * n)


def _buffers(text) -> tuple[np.ndarray, np.ndarray]:
    """Offsets and bytes of an Arrow string array."""
    offsets = np.frombuffer(text.buffers()[1], dtype=np.int32, count=len(text) + 1, offset=4 * text.offset)
    data = np.frombuffer(text.buffers()[2], dtype=np.uint8) if len(text) else np.zeros(0, np.uint8)
    return offsets, data


def _numbers(values: np.ndarray, arrow_type):
    import pyarrow as pa
    import pyarrow.compute as pc

    values = np.ascontiguousarray(values)
    array = pa.Array.from_buffers(arrow_type, values.size, [None, pa.py_buffer(values)])
    return pc.cast(array, pa.string())           # floats: the shortest round-trip digits


def _text_column(values: np.ndarray):
    """One column of a block as an Arrow string array of CSV fields."""
    import pyarrow as pa
    import pyarrow.compute as pc

    n = values.size
    if values.dtype.kind == "f":
        values = values.astype(np.float64, copy=False)
        text = _numbers(values, pa.float64())
        integral = np.isfinite(values) & (values == np.trunc(values))
        if integral.any():   # "100" -> "100.0", "-0" -> "-0.0" (not "1e+16"): floats read as floats
            offsets, data = _buffers(text)
            has_e = np.zeros(n, dtype=bool)
            has_e[np.searchsorted(offsets, np.flatnonzero(data == ord("e")), side="right") - 1] = True
            add = integral & ~has_e
            suffix = _strings(np.where(add, 2, 0), b".0" * int(add.sum()))
            text = pc.binary_join_element_wise(text, suffix, _constant("", n))
        return text
    if values.dtype.kind in "iu":
        return _numbers(values.astype(np.int64, copy=False), pa.int64())
    fields = [_quote(str(v)).encode() for v in values.tolist()]
    return _strings(np.array([len(f) for f in fields], dtype=np.int64), b"".join(fields))


def _float_text(text: str) -> str:
    """Python's ``repr`` of a float rewritten in Arrow's notation (see the module docstring)."""
    if text in ("nan", "inf", "-inf"):
        return text
    sign = "-" if text[0] == "-" else ""
    mantissa, _, exponent = text.lstrip("-").partition("e")
    whole, _, fraction = mantissa.partition(".")
    digits = (whole + fraction).lstrip("0")
    point = len(whole) + int(exponent or 0) - (len(whole) + len(fraction) - len(digits))
    digits = digits.rstrip("0")             # the value is 0.<digits> × 10^point
    if not digits:
        return sign + "0.0"
    if not -6 <= point - 1 < 10:
        head = digits[0] + ("." + digits[1:] if len(digits) > 1 else "")
        return f"{sign}{head}e{'+' if point > 0 else '-'}{abs(point - 1)}"
    if point <= 0:
        return f"{sign}0.{'0' * -point}{digits}"
    if point >= len(digits):
        return f"{sign}{digits}{'0' * (point - len(digits))}.0"
    return f"{sign}{digits[:point]}.{digits[point:]}"


def _python_fields(values: np.ndarray) -> list[str]:
    """One column's CSV fields, formatted in Python (the same text as :func:`_text_column`)."""
    if values.dtype.kind == "f":
        values = values.astype(np.float64, copy=False)
        fields = list(map(float.__repr__, values.tolist()))
        size = np.abs(values)
        # repr already is Arrow's text for 0 and 1e-4 <= |v| < 1e10 (decimal in both notations)
        for i in np.flatnonzero(~((size == 0.0) | ((size >= 1e-4) & (size < 1e10)))).tolist():
            fields[i] = _float_text(fields[i])
        return fields
    if values.dtype.kind in "iu":
        return list(map(str, values.astype(np.int64, copy=False).tolist()))
    return [_quote(str(v)) for v in values.tolist()]


def _write_rows(handle, arrays: list[np.ndarray]) -> None:
    """Write the rows to the text ``handle``: a small table formatted in Python, a large one block
    by block, each column formatted to text, the fields joined with commas and newlines in Arrow,
    the block's UTF-8 bytes written at once."""
    n = arrays[0].shape[0]
    if n * len(arrays) <= SMALL_VALUES:
        if n:
            handle.write("\n".join(map(",".join, zip(*map(_python_fields, arrays)))) + "\n")
        return
    import pyarrow.compute as pc

    for start in range(0, n, ROWS_PER_BLOCK):
        cols = [_text_column(a[start:start + ROWS_PER_BLOCK]) for a in arrays]
        m = len(cols[0])
        rows = pc.binary_join_element_wise(*cols, _constant(",", m)) if len(cols) > 1 else cols[0]
        rows = pc.binary_join_element_wise(rows, _constant("", m), _constant("\n", m))  # row + "\n"
        offsets, data = _buffers(rows)
        handle.flush()               # text already written goes first; the block's bytes as they are
        handle.buffer.write(memoryview(data)[offsets[0]:offsets[-1]])
        del cols, rows, offsets, data
    _release_arrow()


def _release_arrow() -> None:
    """Give back what Arrow's memory pool keeps of the blocks it freed (its allocator holds freed
    blocks for reuse: rows written while the advice runs would keep them through the whole run)."""
    import pyarrow as pa

    pa.default_memory_pool().release_unused()


def metadata_path(csv_path: str | os.PathLike) -> str | None:
    """The CSVW sidecar of a CSV file: ``OUT.csv`` -> ``OUT.csv-metadata.json`` (W3C "CSV on the
    Web" naming), so the CSV itself stays plain for spreadsheets and pandas. None when the CSV goes
    to standard output (``-``), a device or a FIFO (a stream has no place beside it), or when its
    name leaves no room for the suffix within the file system's name limit."""
    text = os.fspath(csv_path)
    if text == "-" or (os.path.exists(text) and not os.path.isfile(text)):
        return None
    sidecar = text + "-metadata.json"
    try:
        name_max = os.pathconf(os.path.dirname(os.path.abspath(text)), "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = 255
    if len(os.fsencode(os.path.basename(sidecar))) > name_max:
        return None
    return sidecar


def write_metadata(csv_path: str | os.PathLike, columns: list[str], record: Mapping[str, str]) -> str | None:
    """Write the CSVW sidecar of ``csv_path``: its columns and a provenance ``record`` (which rule
    table, F and source made it) under ``notes``; atomically. Returns the sidecar's path (None
    for a CSV streamed to ``-``, a device or a FIFO)."""
    import json

    meta = {
        "@context": "http://www.w3.org/ns/csvw",
        "url": os.path.basename(os.fspath(csv_path)),
        "dc:source": record.get("source", ""),
        "dc:creator": record.get("generator", "fuzzyfeed"),
        "tableSchema": {"columns": [{"name": c, "titles": c} for c in columns]},
        "notes": [{"fuzzyfeed": dict(record)}],
    }
    path = metadata_path(csv_path)
    if path is None:
        return None
    with atomic_write(path, "w") as handle:
        handle.write(json.dumps(meta, indent=2, ensure_ascii=False) + "\n")
    return path


def tee(*sinks):
    """One sink of CSV columns handing each piece's rows to every one of ``sinks``."""
    def sink(cols: dict) -> None:
        for each in sinks:
            each(cols)
    return sink
