"""Where compiled code is cached on disk: a user cache folder, never the installed package.

geomint's kernels are compiled with ``njit(cache=CACHE)``.  Left to itself,
numba writes its cache files (``*.nbi``, ``*.nbc``) into ``__pycache__`` beside
the source, which for a non-editable install is ``site-packages/geomint``:
pip does not list those files, so uninstalling leaves a bare
``site-packages/geomint/`` behind that shadows a later editable install.  So
numba is given a locator of geomint's own (registered before any kernel is
defined) that puts the cache of every source file of the package under

    <cache root>/numba/<digest of the package folder>/<sub-package>

The cache root is the first writable folder of

1. ``$GEOMINT_CACHE_DIR``;
2. ``$NUMBA_CACHE_DIR`` (numba's own setting, honoured when geomint's is unset);
3. ``$XDG_CACHE_HOME/geomint``, default ``~/.cache/geomint``;
4. ``<temporary folder>/geomint-<uid>``.

Generated modules of systems written as formulas live under the same root
(``<root>/expressions``), and so does what numba compiles for the user's own
functions that geomint can name again in another process (:func:`keep_compiled`):
``<root>/numba/user/<folder>_<digest of the folder>``, never beside the user's
files.  The digest of the package folder keeps two
checkouts or installs apart.  With no writable folder at all, ``CACHE`` is
False, kernels are compiled anew in every process, and one warning says so.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import warnings
import weakref
from collections.abc import Callable
from pathlib import Path
from typing import Any

from numba.core import caching

PACKAGE = Path(__file__).resolve().parent


def writable(folder: str | os.PathLike[str]) -> bool:
    """True when ``folder`` exists or can be created, and a file can be written in it."""
    try:
        Path(folder).mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def user_folder(name: str) -> Path:
    """``<tmp>/<name>-<uid>``: a per-user folder in the temporary directory."""
    return Path(tempfile.gettempdir()) / f"{name}-{os.getuid() if hasattr(os, 'getuid') else 'user'}"


def candidates() -> list[Path]:
    """The folders that may hold geomint's cache, in order of preference (see the module docstring)."""
    folders = [Path(os.environ[key]) for key in ("GEOMINT_CACHE_DIR", "NUMBA_CACHE_DIR") if os.environ.get(key)]
    user_cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return [*folders, Path(user_cache) / "geomint", user_folder("geomint")]


def cache_root() -> Path | None:
    """The first writable folder of :func:`candidates`, or None when none is writable."""
    return next((folder for folder in candidates() if writable(folder)), None)


def kernel_folder(source_folder: str | os.PathLike[str], root: str | os.PathLike[str] | None = None) -> Path:
    """Where numba caches the compiled code of the package's sources in ``source_folder``."""
    root = cache_root() if root is None else root
    digest = hashlib.sha1(str(PACKAGE).encode()).hexdigest()[:12]
    relative = Path(source_folder).resolve().relative_to(PACKAGE)
    # root is None only with no writable folder, when no kernel is cached (PackageCacheLocator is unused)
    return Path(root) / "numba" / f"geomint-{digest}" / relative  # pyright: ignore[reportArgumentType]


class PackageCacheLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
    """numba's cache locator for the sources of this package: the user cache folder, not ``__pycache__``."""

    def __init__(self, py_func: Callable[..., Any], py_file: str) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = str(kernel_folder(Path(py_file).parent, ROOT))

    def get_cache_path(self) -> str:
        return self._cache_path

    @classmethod
    def from_function(cls, py_func: Callable[..., Any], py_file: str) -> PackageCacheLocator | None:
        if ROOT is None or not Path(py_file).resolve().is_relative_to(PACKAGE):
            return None
        return super().from_function(py_func, py_file)


#: the user functions whose compiled code is kept under the cache root (``keep_compiled``), with the tag that tells
#: apart what numba's own index does not (the globals frozen in, the compile options)
_KEPT: weakref.WeakKeyDictionary[Callable[..., Any], str] = weakref.WeakKeyDictionary()


class UserFunctionLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
    """numba's cache locator for the user functions geomint keeps compiled (``keep_compiled``): under
    ``<root>/numba/user``, a folder per source folder; numba checks the source file's content (its stamp), and the
    disambiguator carries the function's line and its tag."""

    def __init__(self, py_func: Callable[..., Any], py_file: str) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._tag = _KEPT[py_func]
        # ROOT is not None: from_function returns no locator without it
        self._cache_path = str(Path(ROOT) / "numba" / "user" / self.get_suitable_cache_subpath(py_file))  # pyright: ignore[reportArgumentType]

    def get_cache_path(self) -> str:
        return self._cache_path

    def get_disambiguator(self) -> str:
        return f"{self._lineno}.{self._tag}"

    @classmethod
    def from_function(cls, py_func: Callable[..., Any], py_file: str) -> UserFunctionLocator | None:
        if ROOT is None or py_func not in _KEPT:
            return None
        return super().from_function(py_func, py_file)


def keep_compiled(dispatcher: Any, tag: str) -> bool:
    """Have numba keep what it compiles for the user's ``dispatcher`` under the cache root (``UserFunctionLocator``)
    and load it from there in later processes; ``tag`` names what numba's index does not check (the caller's
    ``geomint.model.identity.unseen_part``).  Nothing is done without a writable root or where numba caches the
    function already (``njit(cache=True)``).  Returns whether the function's code is kept here."""
    if ROOT is None or not isinstance(dispatcher._cache, caching.NullCache):
        return dispatcher.py_func in _KEPT
    _KEPT[dispatcher.py_func] = tag
    try:
        dispatcher.enable_caching()
        cache: Any = dispatcher._cache  # a FunctionCache now
        kept = isinstance(cache._impl.locator, UserFunctionLocator)  # never beside the user's files
    except RuntimeError:  # no locator for its file: numba raises
        kept = False
    if not kept:
        dispatcher._cache = caching.NullCache()
        del _KEPT[dispatcher.py_func]
    return kept


def _drop_stale_kernels(root: Path) -> None:
    """Delete numba's on-disk cache of the kernels (``geomint/_kernels``) when any kernel source changed.

    numba invalidates a cached kernel only when the file defining it changes,
    not when a function it calls from another file does; kernels call across
    files, so the whole folder's cache goes when any of its sources changes.
    """
    folder = PACKAGE / "_kernels"
    digest = hashlib.sha256(b"".join(p.read_bytes() for p in sorted(folder.glob("*.py")))).hexdigest()
    cache = kernel_folder(folder, root)
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


def _register():
    if ROOT is None:
        warnings.warn(
            f"geomint: no writable folder for numba's cache ({', '.join(map(str, candidates()))}); "
            "kernels are compiled in every process. Set GEOMINT_CACHE_DIR to a writable folder.",
            RuntimeWarning,
            stacklevel=3,
        )
        return False
    implementation = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # pyright: ignore[reportAttributeAccessIssue]  # renamed in numba 0.61
    locators = implementation._locator_classes
    for locator in (UserFunctionLocator, PackageCacheLocator):
        if locator not in locators:
            locators.insert(0, locator)
    _drop_stale_kernels(ROOT)
    return True


#: the folder every cache of geomint lives under (None: nothing writable)
ROOT = cache_root()
#: ``cache=`` for every ``njit`` of the package
CACHE = _register()
