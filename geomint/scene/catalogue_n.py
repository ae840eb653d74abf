"""What scenes know of the R^n catalogue (``geomint.systems.RN_CATALOGUE``): each system's dimension and form
without building it (``geomint list``), and the limit S_inf its entropy relaxes to where it is known in
closed form (the figures draw S - S_inf from it; ``output.limit = "known"``)."""

from __future__ import annotations

import inspect
import math
from typing import TYPE_CHECKING, Any, NamedTuple

from ..systems import RN_CATALOGUE

if TYPE_CHECKING:
    from collections.abc import Callable


class Dimension(NamedTuple):
    """``n`` as a formula of the arguments (for the listing) and as a function of them."""

    formula: str
    of: Callable[[dict], int]


#: the dimension of each catalogue system from its arguments (a new entry without one is listed by building it)
DIMENSIONS = {
    "random_fish": Dimension("n, its argument", lambda a: int(a["n"])),
    "euler_zeitlin": Dimension("N^2 - 1", lambda a: int(a["N"]) ** 2 - 1),
    "euler_galerkin": Dimension("N^2 - 1", lambda a: int(a["N"]) ** 2 - 1),
    "damped_pendula": Dimension("2N + 1", lambda a: 2 * int(a["N"]) + 1),
    "gas_containers": Dimension("4", lambda a: 4),
    "heat_bath_oscillator": Dimension("3", lambda a: 3),
}


def defaults(name: str) -> dict[str, Any]:
    """The arguments of catalogue system ``name`` with their defaults (``eps`` is a scene's effect)."""
    return {
        k: p.default
        for k, p in inspect.signature(RN_CATALOGUE[name]).parameters.items()
        if k != "eps" and p.default is not inspect.Parameter.empty
    }


def arguments(name: str) -> list[str]:
    """The arguments a scene may give catalogue system ``name`` (every one but ``eps``)."""
    return [k for k in inspect.signature(RN_CATALOGUE[name]).parameters if k != "eps"]


def form(name: str) -> str:
    """``"GENERIC"`` or ``"Fish"``: the class catalogue system ``name`` returns (its annotation)."""
    annotation = inspect.signature(RN_CATALOGUE[name]).return_annotation
    return "GENERIC" if "Generic" in str(getattr(annotation, "__name__", annotation)) else "Fish"


def dimension(name: str, given: dict | None = None) -> int | None:
    """n of catalogue system ``name`` with these arguments (defaults for the rest); None if not tabulated."""
    if name not in DIMENSIONS:
        return None
    return DIMENSIONS[name].of({**defaults(name), **(given or {})})


class Limit(NamedTuple):
    """S_inf in closed form: what it is (for keys and summaries) and its value from the start ``x0``."""

    why: str
    value: Callable[[Any, Any, dict], float]


def _pendula(system, x0, arguments):
    return float(system.H(x0)) + (system.dim - 1) // 2


def _gas(system, x0, arguments):
    return 3.0 * math.log(float(system.H(x0)) / 2.0)


def _bath(system, x0, arguments):
    values = {**defaults("heat_bath_oscillator"), **arguments}
    return values["c"] * math.log(float(system.H(x0)) / (values["c"] * values["T0"]))


def _euler(system, x0, arguments):
    return float(system.H(x0))


#: the closed-form limits, and what they need of the effects: (limit, needs the Hamiltonian part, the
#: friction argument that must be > 0)
KNOWN_LIMITS = {
    "euler_zeitlin": (Limit("S_inf = H0: the lowest shell |k|^2 = 1, where S = H", _euler), False, None),
    "euler_galerkin": (Limit("S_inf = H0: the lowest shell |k|^2 = 1, where S = H", _euler), False, None),
    "damped_pendula": (Limit("S_inf = E0 + N: every pendulum at rest at cos q = -1", _pendula), True, "gamma"),
    "gas_containers": (Limit("S_inf = 3 ln(E0 / 2): equal temperatures and pressures", _gas), True, "gamma"),
    "heat_bath_oscillator": (Limit("S_inf = c ln(E0 / (c T0)): the oscillator at rest", _bath), True, "gamma"),
}


def known_limit(name: str, arguments: dict, hamiltonian: bool, eps: float) -> Limit | None:
    """The closed-form S_inf of catalogue system ``name`` under these effects, or None where it has none (or
    where the effects change it: no dissipation, or pendula without their Hamiltonian part stop where they
    are)."""
    if name not in KNOWN_LIMITS or eps <= 0.0:
        return None
    limit, needs_hamiltonian, friction = KNOWN_LIMITS[name]
    if needs_hamiltonian and not hamiltonian:
        return None
    if friction is not None and not {**defaults(name), **arguments}.get(friction, 1.0) > 0.0:
        return None
    return limit


def expected_rate(name: str, arguments: dict, hamiltonian: bool, eps: float, H0: float) -> tuple[float, str] | None:
    """The rate at which ``|S - S_inf|`` is expected to decay near the end, from the linearisation at the
    limit, with what it is (for a key), or None where the catalogue has none:

    * 2-D Euler: ``8 eps H0``, the slowest shell (|k|^2 = 2) under the dissipative part alone (the Hamiltonian
      part's mixing makes the whole flow faster);
    * the heat bath: ``gamma / m``, the decay of the damped oscillator's energy (underdamped);
    * the damped pendula: ``gamma``, the same for each pendulum near the bottom (mass 1, stiffness 1).
    """
    if eps <= 0.0:
        return None
    values = {**defaults(name), **arguments} if name in RN_CATALOGUE else {}
    if name in ("euler_zeitlin", "euler_galerkin"):
        return 8.0 * eps * H0, f"8 ε H0 = {8.0 * eps * H0:.4g} (linearised, dissipative part alone)"
    if not hamiltonian:
        return None
    if name == "heat_bath_oscillator":
        m, k, gamma = values["m"], values["k"], values["gamma"]
        if gamma > 0 and gamma * gamma < 4 * m * k:
            return gamma / m, f"γ/m = {gamma / m:.4g} (the damped oscillator's energy, linearised)"
    if name == "damped_pendula":
        gamma = values["gamma"]
        if 0 < gamma < 2:
            return gamma, f"γ = {gamma:.4g} (each pendulum's energy near the bottom, linearised)"
    return None
