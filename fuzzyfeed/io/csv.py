"""CSV written for machines and spreadsheets: a header with units, full float precision, atomic.

Floats are written with Python's ``repr`` (the shortest text that reads back to the same float64),
so pandas/numpy read the exact values back. A NaN or infinite value is refused before anything is
written: fuzzyfeed never exports a feed it could not compute.
"""

from __future__ import annotations

import csv
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
    as_lists = [a.tolist() for a in arrays]
    with atomic_write(path, "w", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(names)
        writer.writerows(zip(*as_lists))


def metadata_path(csv_path: str | os.PathLike) -> str:
    """The CSVW sidecar of a CSV file: ``OUT.csv`` -> ``OUT.csv-metadata.json`` (W3C "CSV on the
    Web" naming), so the CSV itself stays plain for spreadsheets and pandas."""
    return os.fspath(csv_path) + "-metadata.json"


def write_metadata(csv_path: str | os.PathLike, columns: list[str], record: Mapping[str, str]) -> str:
    """Write the CSVW sidecar of ``csv_path``: its columns and a provenance ``record`` (which rule
    table, F and source made it) under ``notes``; atomically. Returns the sidecar's path."""
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
    with atomic_write(path, "w") as handle:
        handle.write(json.dumps(meta, indent=2, ensure_ascii=False) + "\n")
    return path
