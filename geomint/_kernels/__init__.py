"""Compiled kernels: numba only, no classes, no validation, no I/O.

Every kernel trusts its caller (`geomint.solve` or `MetriplecticSystem`) to have
checked shapes, finiteness and function types.  The model reaches a kernel as
one value, ``layout.Model``: the user functions as typed first-class functions
and the params, so that one cached compilation serves every system of the same
function types (docs/design.md section 5).  numba warns at each compilation
that first-class function types are experimental; the user cannot act on that,
so this one warning is filtered (by its message, nothing else).
"""

import hashlib
import warnings
from pathlib import Path

from numba.core.errors import NumbaExperimentalFeatureWarning

from .._cache import ROOT, kernel_folder

warnings.filterwarnings(
    "ignore", message=".*First-class function type feature is experimental", category=NumbaExperimentalFeatureWarning
)


def _drop_stale_cache():
    """Delete numba's on-disk cache of these kernels when any kernel source changed.

    numba invalidates a cached kernel only when the file defining it changes,
    not when a function it calls from another file does; kernels here call
    across files, so the whole folder's cache goes when any of its sources
    changes.
    """
    folder = Path(__file__).parent
    if ROOT is None:
        return
    digest = hashlib.sha256(b"".join(p.read_bytes() for p in sorted(folder.glob("*.py")))).hexdigest()
    cache = kernel_folder(folder, ROOT)
    stamp = cache / "geomint-kernels.sha256"
    try:
        if stamp.exists() and stamp.read_text() == digest:
            return
        cache.mkdir(parents=True, exist_ok=True)
        for path in (*cache.glob("*.nbi"), *cache.glob("*.nbc")):
            path.unlink()
        stamp.write_text(digest)
    except OSError:  # a cache folder that cannot be cleaned is one numba cannot write either
        pass


_drop_stale_cache()
