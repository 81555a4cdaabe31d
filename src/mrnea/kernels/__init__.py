"""Numba kernels, one algorithm per file (see each file's docstring and docs/notation.md).

Numba caches each compiled kernel on disk, keyed by the timestamp of the kernel's own file only,
not of the kernels it calls: after an edit to ``common.py``, say, ``aba.py``'s cache would still
hold machine code built from the old ``common.py``. So the cached kernels are dropped whenever
any kernel source changes (a hash of all of them, checked at import, about a millisecond).
"""

from __future__ import annotations

import hashlib
from pathlib import Path


def _drop_stale_cache() -> None:
    here = Path(__file__).parent
    digest = hashlib.sha256(b"".join(p.read_bytes() for p in sorted(here.glob("*.py"))))
    cache = here / "__pycache__"
    stamp = cache / "mrnea-kernels.sha256"
    try:
        if stamp.read_text() == digest.hexdigest():
            return
    except OSError:
        pass
    try:
        cache.mkdir(exist_ok=True)
        for f in cache.glob("*.nb[ci]"):
            f.unlink()
        stamp.write_text(digest.hexdigest())
    except OSError:  # a read-only install: Numba then uses its own cache folder
        pass


_drop_stale_cache()
