"""CSV written for machines and spreadsheets: a header with units, full float precision, atomic.

Floats are written as the shortest text that reads back to the same float64 (what Python's
``repr`` guarantees), so pandas/numpy read the exact values back. The digits come from Apache
Arrow's float-to-string cast (double-conversion's shortest mode), in C++ and by blocks of rows,
about 4× faster than Python's csv module; an integral value gets a trailing ``.0`` as ``repr``
writes it, so every float column still reads back as float64. Other columns are written as
Python's csv module would (quoted only when needed). A NaN or infinite value is refused before
anything is written: fuzzyfeed never exports a feed it could not compute.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np

from fuzzyfeed.errors import ExportError
from fuzzyfeed.io.atomic import atomic_write


def write_columns(path: str | os.PathLike, columns: Mapping[str, np.ndarray],
                  allow_nan: tuple[str, ...] = ()) -> None:
    """Write equal-length columns to ``path`` (header = the keys), atomically."""
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


#: Rows formatted per block (bounds the memory of the text: ~15 MB for 11 float columns).
ROWS_PER_BLOCK = 1 << 16


def _quote(text: str) -> str:
    """A field as Python's csv module writes it (quoted only when it holds , " or a line break)."""
    if any(c in text for c in ',"\r\n'):
        return '"' + text.replace('"', '""') + '"'
    return text


def _text_column(values: np.ndarray):
    """One column of a block as an Arrow string array of CSV fields."""
    import pyarrow as pa
    import pyarrow.compute as pc

    if values.dtype.kind == "f":
        values = values.astype(np.float64, copy=False)
        text = pc.cast(pa.array(values), pa.string())            # shortest round-trip digits
        integral = np.isfinite(values) & (values == np.trunc(values))
        if integral.any():   # "100" -> "100.0", "-0" -> "-0.0" (not "1e+16"): floats read as floats
            plain = pc.invert(pc.match_substring(text, "e"))
            add = pc.and_(pa.array(integral), plain)
            text = pc.if_else(add, pc.binary_join_element_wise(text, ".0", ""), text)
        return text
    if values.dtype.kind in "iu":
        return pc.cast(pa.array(values), pa.string())
    return pa.array([_quote(str(v)) for v in values.tolist()], type=pa.string())


def _write_rows(handle, arrays: list[np.ndarray]) -> None:
    """Write the rows to the text ``handle``, block by block: each column formatted to text, the
    fields joined with commas and newlines in Arrow, the block's UTF-8 bytes written at once."""
    import pyarrow.compute as pc

    n = arrays[0].shape[0]
    for start in range(0, n, ROWS_PER_BLOCK):
        cols = [_text_column(a[start:start + ROWS_PER_BLOCK]) for a in arrays]
        rows = pc.binary_join_element_wise(*cols, ",") if len(cols) > 1 else cols[0]
        rows = pc.binary_join_element_wise(rows, "", "\n")     # each row + "\n"
        offsets = np.frombuffer(rows.buffers()[1], dtype=np.int32, count=len(rows) + 1,
                                offset=4 * rows.offset)
        data = memoryview(rows.buffers()[2])[offsets[0]:offsets[-1]]
        handle.flush()               # text already written goes first; the block's bytes as they are
        handle.buffer.write(data)
