"""Keep freed memory in the process for the next arrays, instead of handing it back at once.

glibc's ``malloc`` serves a request of 128 KiB or more (its starting ``M_MMAP_THRESHOLD``) with
a fresh ``mmap`` and returns it to the system when it is freed, and it gives back the top of
its heap once more than ``M_TRIM_THRESHOLD`` of it is free. Every page of such memory is then
faulted in again at its first write: on the shared virtual machines these benchmarks run on,
1 to 4 us per 4 KiB page. The identifier and the candidates' scoring build numpy temporaries
of 100 KiB to a few MiB at every picture (an ``(R, K, C, S)`` array of 30 robots is 170 KiB),
so a learning run faulted in about 125 pages per decision of a copy of 30 robots, and an
``exp`` over 86,000 numbers cost 0.83 ms with its faults against 0.09 ms without.

``keep_freed_memory`` raises both thresholds (``mallopt``), so that those arrays reuse the
heap's memory: a few hundred MiB may then stay with the process after a large step. The
learning path (``agents.vec.AnonLocVecEnv``) calls it; nothing else does, since it changes the
whole process. Elsewhere than on glibc, or with ``ANONLOC_MALLOC=0`` in the environment, it
does nothing.
"""

from __future__ import annotations

import ctypes
import os
import platform

#: ``mallopt`` parameters (glibc's ``malloc.h``).
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: Requests below this come from the heap (glibc's largest allowed value on 64-bit systems).
MMAP_THRESHOLD = 32 * 1024 * 1024
#: The heap keeps up to this much free memory at its top.
TRIM_THRESHOLD = 256 * 1024 * 1024

_DONE: list[bool] = []


def keep_freed_memory() -> bool:
    """Raise glibc's ``M_MMAP_THRESHOLD`` to ``MMAP_THRESHOLD`` and ``M_TRIM_THRESHOLD`` to
    ``TRIM_THRESHOLD`` for this process (once; see the module doc). Returns whether they are
    set: False off glibc, with ``ANONLOC_MALLOC=0``, or if ``mallopt`` refused."""
    if _DONE:
        return _DONE[0]
    done = False
    if os.environ.get("ANONLOC_MALLOC", "1") != "0" and platform.libc_ver()[0] == "glibc":
        try:
            mallopt = ctypes.CDLL(None).mallopt
        except (OSError, AttributeError):
            mallopt = None
        if mallopt is not None:
            mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
            mallopt.restype = ctypes.c_int
            done = bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(
                mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD)
            )
    _DONE.append(done)
    return done
