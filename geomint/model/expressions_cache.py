"""Where the generated modules of systems written as formulas live, and how they are imported.

``<cache root>/expressions`` (the root of ``geomint._cache``): ``geomint_expr_<sha256 of the source>.py``,
decorated with ``numba.njit(cache=True)`` so numba's cache beside it serves a second process.  No sympy
here: a system found in the cache (``expressions_n``) is loaded without importing it.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
from typing import TYPE_CHECKING

from .. import _cache

if TYPE_CHECKING:
    from pathlib import Path
    from types import ModuleType


def cache_directory() -> Path:
    """Where generated modules live: ``<cache root>/expressions`` (``geomint._cache``)."""
    root = _cache.cache_root()
    if root is None or not _cache.writable(root / "expressions"):
        raise OSError(
            f"no writable folder for generated code among {[str(c) for c in _cache.candidates()]}; "
            "set GEOMINT_CACHE_DIR to a writable folder."
        )
    return root / "expressions"


def compile_functions(text: str) -> ModuleType:
    """Import the generated module ``text`` from the disk cache (writing it first if new).

    The module is named ``geomint_expr_<sha256 of text>``; an existing file is
    not rewritten, so numba's cache (keyed by the file and its time stamp)
    stays valid and a new process loads compiled code instead of compiling.
    """
    name = "geomint_expr_" + hashlib.sha256(text.encode()).hexdigest()[:20]
    if name in sys.modules:
        return sys.modules[name]
    path = cache_directory() / f"{name}.py"
    if not path.is_file() or path.read_text(encoding="utf-8") != text:
        partial = path.with_suffix(f".{os.getpid()}.tmp")
        partial.write_text(text, encoding="utf-8")
        os.replace(partial, path)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)  # pyright: ignore[reportArgumentType]  # a .py path: a spec
    sys.modules[name] = module
    spec.loader.exec_module(module)  # pyright: ignore[reportOptionalMemberAccess]
    return module
