"""Results that last: a ``Solution`` to and from ``.npz``, and to ``xarray``.

File layout (``numpy.savez_compressed``, no pickles: ``numpy.load(path,
allow_pickle=False)`` reads it):

- arrays ``t (m,)``, ``x (m, n)``, ``H (m,)``, ``S (m,)`` (n = 3 in R^3);
- ``metadata``: one JSON string with ``format``, ``format_version``, the
  geomint version (no git state), the status fields and work counts, the
  dimension ``dim``, the direction of S (``S_direction``: -1 where S never
  rises, the Fish form; +1 where it never falls, GENERIC's entropy), the
  method as data (``geomint.integrators.data``: name and options, nested) and,
  when given, the system (name, form ``"Fish"`` or ``"GENERIC"``, dimension,
  the names of its coordinates, direction of S, parameters, eps, effects, and
  its formulas when it was built from expressions).

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
    """The JSON-ready description of ``solution`` (and of ``system``, if given) that ``save`` writes; a ``system``
    of another dimension or direction of S than the solution's is refused, naming ``system``."""
    from .._version import __version__

    method = solution.method
    dim, direction = _dim(solution), S_direction(solution)
    if system is not None:
        _check_system(system, dim, direction)
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "geomint": __version__,
        **{key: _plain(getattr(solution, key)) for key in _SCALARS},
        "dim": dim,
        "S_direction": direction,
        "method": method_to_data(method) if isinstance(method, Integrator) else str(method),
        "system": None if system is None else system_metadata(system),
        # why a successful run may not be accurate (optional keys: files written before them read as none)
        "caveats": list(getattr(solution, "caveats", ())),
        "step_ratio": _plain(getattr(solution, "step_ratio", None)),
    }


def system_metadata(system: MetriplecticSystem) -> dict[str, Any]:
    """``{"name", "form", "dim", "variables", "direction", "params", "eps", "hamiltonian"}`` of a system, with
    ``"expressions"`` when it has formulas.  ``form`` is ``"GENERIC"`` for a ``GenericSystem`` (S the entropy,
    ``direction`` +1: it never falls), else ``"Fish"`` (S the Casimir, ``direction`` -1: it never rises)."""
    data: dict[str, Any] = {
        "name": system.name,
        "form": "GENERIC" if system.direction > 0 else "Fish",
        "dim": int(system.dim),
        "variables": list(system.variables),
        "direction": float(system.direction),
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


def _opened(path: str | os.PathLike[str]) -> Any:  # numpy's NpzFile
    """``np.load(path)`` of a file ``save`` wrote, an npz (zip) archive; any other file is refused by what it is
    not (numpy reads a file that is not an archive as a pickle, and its refusal advises loading it unsafely)."""
    with open(path, "rb") as file:
        if file.read(4) != b"PK\x03\x04":
            raise ValueError(
                f"`path` {str(path)!r} is not a geomint solution file (not an .npz archive); write one with "
                "Solution.save."
            )
    return np.load(path, allow_pickle=False)


def read_metadata(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The metadata dict of a file written by ``save`` (``ValueError`` naming the path if it is not one)."""
    with _opened(path) as data:
        return _metadata(path, data)


def read(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The fields of the ``Solution`` saved at ``path``, as keyword arguments (``geomint.load`` builds it);
    its ``method`` is rebuilt from its data form.

    A method that cannot be rebuilt (saved by a newer geomint, or not an
    integrator, e.g. a scipy label) comes back as its data form.
    """
    with _opened(path) as data:
        meta = _metadata(path, data)
        arrays = {key: data[key] for key in _ARRAYS}
    try:
        method = method_from_data(meta["method"]) if isinstance(meta["method"], dict) else meta["method"]
    except MethodDataError:
        method = meta["method"]
    caveats = {"caveats": tuple(meta.get("caveats") or ()), "step_ratio": meta.get("step_ratio")}
    # files written before the direction was recorded hold runs in R^3, where S never rises
    direction = float(meta.get("S_direction", -1.0))
    return {**arrays, **{key: meta[key] for key in _SCALARS}, "method": method, **caveats, "S_direction": direction}


def to_xarray(solution: Solution, system: MetriplecticSystem | None = None) -> Any:  # an xarray.Dataset
    """An ``xarray.Dataset``: ``x (t, component)``, ``H (t)``, ``S (t)``; the metadata as attributes.

    ``component`` is labelled with the system's ``variables`` (without a
    system: ``x, y, z`` in R^3, ``x0, x1, ...`` in R^n).  Attributes hold
    scalars and the method/system as JSON strings (netCDF-safe), and what S is:
    ``S_direction`` (-1.0 or +1.0) and ``S_meaning`` (``"entropy: never falls
    (GENERIC)"`` or ``"Casimir: never rises (Fish form)"``), also on ``S``
    itself (``long_name``, ``direction``).  Needs the optional ``xarray``
    (``pip install geomint[xarray]``).
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
    direction = meta["S_direction"]
    attrs.update(direction_attrs(direction))
    names = list(system.variables) if system is not None else default_variables(meta["dim"])
    data = xarray.Dataset(
        {"x": (("t", "component"), solution.x), "H": ("t", solution.H), "S": ("t", solution.S)},
        coords={"t": solution.t, "component": names},
        attrs=attrs,
    )
    data["S"].attrs.update(S_attrs(direction))
    data["H"].attrs["long_name"] = "energy"
    return data


def default_variables(dim: int) -> list[str]:
    """The names of the coordinates where no system says them: ``x, y, z`` in R^3, ``x0, x1, ...`` in R^n."""
    return ["x", "y", "z"] if dim == 3 else [f"x{i}" for i in range(dim)]


def S_direction(solution: Solution) -> float:
    """The direction of S of the system ``solution`` came from: -1.0 (S never rises) or +1.0 (never falls)."""
    return float(getattr(solution, "S_direction", -1.0))


def direction_attrs(direction: float) -> dict[str, Any]:
    """Attributes of a dataset saying what S is: ``S_direction`` and ``S_meaning``."""
    meaning = "entropy: never falls (GENERIC)" if direction > 0 else "Casimir: never rises (Fish form)"
    return {"S_direction": float(direction), "S_meaning": meaning}


def S_attrs(direction: float) -> dict[str, str]:
    """Attributes of the variable S: ``long_name`` (entropy or Casimir) and ``direction``."""
    if direction > 0:
        return {"long_name": "entropy", "direction": "never falls"}
    return {"long_name": "Casimir", "direction": "never rises"}


def _dim(solution):
    x = np.asarray(solution.x)
    return int(x.shape[1]) if x.ndim == 2 else 3


def _check_system(system, dim, direction):
    if int(system.dim) != dim or float(system.direction) != direction:
        raise ValueError(
            f"`system` {system.name!r} (in R^{system.dim}, S direction {float(system.direction):+g}) is not the "
            f"system of this solution (states in R^{dim}, S direction {direction:+g}); pass the system it was "
            "solved with, or none."
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
