"""What a method is: small declarative objects with traits; no step loops.

Each integrator lowers itself (``lower(system)``) to step data for the shared
engine in ``geomint._kernels``.  ``INTEGRATORS`` is the one table of short names.
"""

from typing import Any

from .base import Integrator, Traits
from .composition import SCHEMES, Composition, KahanLi6, KahanLi8, Suzuki4, SuzukiUmeno8, Yoshida4, Yoshida6
from .discrete_gradient import AVF, DampedGonzalez, DiscreteGradient, Gonzalez, ItohAbe, SymmetrizedItohAbe
from .exact_flows import OscillatorRotation, RigidBodyFlow, RotorSplitting
from .projection import Projected
from .runge_kutta import RK4, BogackiShampine32, DormandPrince54, DormandPrince853, EmbeddedRungeKutta
from .splitting import Lie, Strang

#: short name -> class, for ``solve(method="gonzalez")``, scenes and the command line
INTEGRATORS = {
    cls.name: cls
    for cls in (
        Gonzalez,
        ItohAbe,
        SymmetrizedItohAbe,
        AVF,
        DampedGonzalez,
        RK4,
        BogackiShampine32,
        DormandPrince54,
        DormandPrince853,
        Lie,
        Strang,
        Projected,
        Yoshida4,
        Suzuki4,
        Yoshida6,
        KahanLi6,
        SuzukiUmeno8,
        KahanLi8,
        RigidBodyFlow,
        RotorSplitting,
        OscillatorRotation,
    )
}


def resolve(method: Integrator | str) -> Integrator:
    """An ``Integrator`` from an instance or a short name such as ``"gonzalez"`` (default options)."""
    if isinstance(method, Integrator):
        return method
    if isinstance(method, str) and method.lower() in INTEGRATORS:
        return INTEGRATORS[method.lower()]()
    raise ValueError(f"`method` must be an Integrator instance or one of {sorted(INTEGRATORS)}; got {method!r}.")


__all__ = [
    "AVF",
    "BogackiShampine32",
    "Composition",
    "DampedGonzalez",
    "DiscreteGradient",
    "DormandPrince54",
    "DormandPrince853",
    "EmbeddedRungeKutta",
    "Gonzalez",
    "INTEGRATORS",
    "Integrator",
    "ItohAbe",
    "KahanLi6",
    "KahanLi8",
    "Lie",
    "OscillatorRotation",
    "Projected",
    "RK4",
    "RigidBodyFlow",
    "RotorSplitting",
    # S_rise_statistics (now geomint.studies'), the earlier public name, is resolved by __getattr__ below
    "SCHEMES",
    "S_rise_statistics",  # pyright: ignore[reportUnsupportedDunderAll]
    "Strang",
    "Suzuki4",
    "SuzukiUmeno8",
    "SymmetrizedItohAbe",
    "Traits",
    "Yoshida4",
    "Yoshida6",
    "resolve",
]


def __getattr__(name: str) -> Any:
    """``S_rise_statistics``, which runs a method and moved to ``geomint.studies``, under its earlier name here
    (PEP 562).  studies is imported by name, on first use: it imports this package, which imports no studies."""
    if name == "S_rise_statistics":
        import importlib

        return importlib.import_module(f"{__name__.rpartition('.')[0]}.studies").S_rise_statistics
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), "S_rise_statistics"})
