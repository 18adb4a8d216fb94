"""Keep the memory of large arrays returnable to the system (glibc).

glibc serves a block above its mmap threshold (128 KiB at start) with its own ``mmap`` and gives
it back on ``free``; but each time such a block is freed it *raises* the threshold to that block's
size (up to 32 MiB), so the next arrays of a few MB come from the heap, whose freed space stays in
the process. Reading a 10⁶-line program makes and drops hundreds of 8 MB columns: with the moving
threshold they pile up (the peak RSS of ``advise`` on the 10⁶-line raster: 1.15 GB; with a fixed
threshold of 1 MiB 0.86 GB, for about 1.5 s more system time in page faults).
:func:`fix_mmap_threshold` fixes the threshold (``mallopt(M_MMAP_THRESHOLD, …)``, which also stops
the adjustment). Elsewhere than glibc it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys
from functools import cache

#: glibc's mallopt parameter number of M_MMAP_THRESHOLD.
_M_MMAP_THRESHOLD = -3
#: Blocks from this size on are mmapped (and returned when freed).
MMAP_THRESHOLD_BYTES = 1 << 20


@cache
def _libc():
    """The C library (loaded once), or None where it is not glibc on Linux or cannot be loaded."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    except OSError:
        return None


def fix_mmap_threshold(nbytes: int = MMAP_THRESHOLD_BYTES) -> bool:
    """Fix glibc's mmap threshold at ``nbytes``; True when it was set."""
    mallopt = getattr(_libc(), "mallopt", None)
    if mallopt is None:
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, int(nbytes)))


def release_free_memory() -> bool:
    """Give the heap's free pages back to the system (glibc ``malloc_trim(0)``): after a stage
    that made and dropped many arrays under the mmap threshold (the advice in pieces of a 10⁶-move
    cut leaves ~80 MB of freed heap in the process otherwise); True when it ran."""
    trim = getattr(_libc(), "malloc_trim", None)
    if trim is None:
        return False
    trim.argtypes = (ctypes.c_size_t,)
    trim.restype = ctypes.c_int
    trim(0)
    return True
