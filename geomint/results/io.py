"""Results that last: a ``Solution`` to and from ``.npz``, and to ``xarray``.

File layout (``numpy.savez_compressed``, no pickles: ``numpy.load(path,
allow_pickle=False)`` reads it):

- arrays ``t (n,)``, ``x (n, 3)``, ``H (n,)``, ``S (n,)``;
- ``metadata``: one JSON string with ``format``, ``format_version``, the
  geomint version (no git state), the status fields and work counts, the
  method as data (``geomint.integrators.data``: name and options, nested) and,
  when given, the system (name, parameters, eps, effects, and its formulas
  when it was built from expressions).

>>> import geomint, tempfile, os
>>> body = geomint.systems.relaxing_rigid_body(eps=0.1)
>>> sol = geomint.solve(body, [0.6, 0.0, 0.8], (0.0, 1.0), 0.1)
>>> path = sol.save(os.path.join(tempfile.mkdtemp(), "run"), system=body)
>>> again = geomint.load(path)
>>> bool((again.x == sol.x).all()), again.method == sol.method
(True, True)
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._files import atomic
from ..integrators import Integrator
from ..integrators.data import MethodDataError, method_from_data, method_to_data

if TYPE_CHECKING:
    import os

    from ..model.system import MetriplecticSystem

    #: a ``Solution`` (not imported here: ``results.solution`` imports this module)
    Solution = Any

FORMAT = "geomint-solution"
FORMAT_VERSION = 1
_ARRAYS = ("t", "x", "H", "S")
_SCALARS = ("success", "status", "message", "failed_step", "n_steps", "n_newton", "nfev")


def metadata(solution: Solution, system: MetriplecticSystem | None = None) -> dict[str, Any]:
    """The JSON-ready description of ``solution`` (and of ``system``, if given) that ``save`` writes."""
    from .._version import __version__

    method = solution.method
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "geomint": __version__,
        **{key: _plain(getattr(solution, key)) for key in _SCALARS},
        "method": method_to_data(method) if isinstance(method, Integrator) else str(method),
        "system": None if system is None else system_metadata(system),
        # why a successful run may not be accurate (optional keys: files written before them read as none)
        "caveats": list(getattr(solution, "caveats", ())),
        "step_ratio": _plain(getattr(solution, "step_ratio", None)),
    }


def system_metadata(system: MetriplecticSystem) -> dict[str, Any]:
    """``{"name", "params", "eps", "hamiltonian"}`` of a system, with ``"expressions"`` when it has formulas."""
    data: dict[str, Any] = {
        "name": system.name,
        "params": system.params.tolist(),
        "eps": system.eps,
        "hamiltonian": system.hamiltonian,
    }
    if getattr(system, "expressions", None) is not None:
        data["expressions"] = system.expressions
    return data


def save(solution: Solution, path: str | os.PathLike[str], system: MetriplecticSystem | None = None) -> Path:
    """Write ``solution`` to ``path`` (``.npz`` appended if missing); returns the path written.

    ``system`` (optional) is recorded in the metadata: name, parameters, eps.
    """
    if not all(hasattr(solution, key) for key in (*_ARRAYS, *_SCALARS, "method")):
        raise TypeError(f"`solution` must be a geomint.Solution; got {type(solution).__name__}.")
    path = Path(path)
    path = path if path.suffix == ".npz" else path.with_name(path.name + ".npz")
    text = json.dumps(metadata(solution, system))
    with atomic(path) as temporary:
        np.savez_compressed(temporary, **{key: getattr(solution, key) for key in _ARRAYS}, metadata=np.array(text))
    return path


def read_metadata(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The metadata dict of a file written by ``save`` (``ValueError`` naming the path if it is not one)."""
    with np.load(path, allow_pickle=False) as data:
        return _metadata(path, data)


def read(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The fields of the ``Solution`` saved at ``path``, as keyword arguments (``geomint.load`` builds it);
    its ``method`` is rebuilt from its data form.

    A method that cannot be rebuilt (saved by a newer geomint, or not an
    integrator, e.g. a scipy label) comes back as its data form.
    """
    with np.load(path, allow_pickle=False) as data:
        meta = _metadata(path, data)
        arrays = {key: data[key] for key in _ARRAYS}
    try:
        method = method_from_data(meta["method"]) if isinstance(meta["method"], dict) else meta["method"]
    except MethodDataError:
        method = meta["method"]
    caveats = {"caveats": tuple(meta.get("caveats") or ()), "step_ratio": meta.get("step_ratio")}
    return {**arrays, **{key: meta[key] for key in _SCALARS}, "method": method, **caveats}


def to_xarray(solution: Solution, system: MetriplecticSystem | None = None) -> Any:  # an xarray.Dataset
    """An ``xarray.Dataset``: ``x (t, component)``, ``H (t)``, ``S (t)``; the metadata as attributes.

    Attributes hold scalars and the method/system as JSON strings (netCDF-safe).
    Needs the optional ``xarray`` (``pip install geomint[xarray]``).
    """
    try:
        import xarray
    except ImportError:
        raise ImportError(
            "Solution.to_xarray needs xarray, an optional dependency of geomint: pip install geomint[xarray]"
        ) from None
    meta = metadata(solution, system)
    attrs = {
        key: json.dumps(value) if isinstance(value, (dict, list)) or value is None else value
        for key, value in meta.items()
    }
    attrs["success"] = int(attrs["success"])
    return xarray.Dataset(
        {"x": (("t", "component"), solution.x), "H": ("t", solution.H), "S": ("t", solution.S)},
        coords={"t": solution.t, "component": ["x", "y", "z"]},
        attrs=attrs,
    )


def _metadata(path, data):
    if "metadata" not in data.files:
        raise ValueError(
            f"`path` {str(path)!r} is not a geomint solution file (no metadata); write one with Solution.save."
        )
    meta = json.loads(str(data["metadata"]))
    if meta.get("format") != FORMAT or meta.get("format_version", 0) > FORMAT_VERSION:
        raise ValueError(
            f"`path` {str(path)!r} holds format {meta.get('format')!r} version "
            f"{meta.get('format_version')!r}; this geomint reads {FORMAT!r} up to version "
            f"{FORMAT_VERSION}. Upgrade geomint."
        )
    return meta


def _plain(value):
    return value.item() if isinstance(value, np.generic) else value
