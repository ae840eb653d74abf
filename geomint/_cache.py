"""Where compiled code is cached on disk, and what happens when no folder is writable.

geomint's kernels are compiled with ``njit(cache=CACHE)``.  numba caches next
to the source (``__pycache__``), else in the user's cache folder; a read-only
install with a read-only home (containers, clusters) has neither, and numba
would refuse to even define a cached function ("no locator available").  So,
before any kernel is defined: if neither is writable, numba's cache goes to a
folder in the temporary directory (``numba.config.CACHE_DIR``); if that is not
writable either, ``CACHE`` is False, kernels are compiled anew in every
process, and one warning says so.  A ``NUMBA_CACHE_DIR`` the user set is left
alone.
"""

import os
import tempfile
import warnings
from pathlib import Path

import numba


def writable(folder):
    """True when ``folder`` exists or can be created, and a file can be written in it."""
    try:
        Path(folder).mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def user_folder(name):
    """``<tmp>/<name>-<uid>``: a per-user folder in the temporary directory."""
    return Path(tempfile.gettempdir()) / f"{name}-{os.getuid() if hasattr(os, 'getuid') else 'user'}"


def _numba_cache():
    if numba.config.CACHE_DIR:
        return True
    here = Path(__file__).parent
    if all(writable(folder / "__pycache__") for folder in (here, here / "_kernels", here / "systems")):
        return True
    from numba.misc.appdirs import AppDirs

    if writable(AppDirs(appname="numba", appauthor=False).user_cache_dir):
        return True
    fallback = user_folder("geomint-numba")
    if writable(fallback):
        numba.config.CACHE_DIR = str(fallback)
        return True
    warnings.warn(f"geomint: no writable folder for numba's cache (the install, the user cache, {fallback}); "
                  "kernels are compiled in every process. Set NUMBA_CACHE_DIR to a writable folder.",
                  RuntimeWarning, stacklevel=2)
    return False


#: ``cache=`` for every ``njit`` of the package
CACHE = _numba_cache()
