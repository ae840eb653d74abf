"""Hypothesis strategies and assertion helpers for testing conservation and dissipation.

Use them in your own tests to check that geomint keeps *your* system's energy
and lowers its Casimir, step by step, with tolerances in ulps of the terms::

    from hypothesis import given
    import geomint, geomint.testing as gt

    @given(x=gt.states(), h=gt.step_sizes())
    def test_my_system_is_exact(x, h):
        gt.assert_step_invariants(my_system, geomint.Gonzalez(), x, h)

Requires ``hypothesis`` (``pip install geomint[test]``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Literal

import numpy as np
from hypothesis import assume, reject
from hypothesis import strategies as st

from . import _validate
from . import systems as _catalogue
from .diagnostics import observed_order  # noqa: F401 (re-exported for tests)
from .integrators import INTEGRATORS
from .run.solve import solve
from .studies import measured_order, reference_solution  # noqa: F401 (re-exported for tests)

if TYPE_CHECKING:
    import numpy.typing as npt

    from .integrators import Integrator
    from .model.system import MetriplecticSystem

    Vector = npt.NDArray[np.float64]

EPS = np.finfo(np.float64).eps


# -- strategies -----------------------------------------------------------------------
def states(bound: float = 2.0, min_norm: float = 1e-2) -> st.SearchStrategy[Vector]:
    """States in the box ``[-bound, bound]^3`` with ``|x| >= min_norm``, as float64 arrays."""
    coordinate = st.floats(-bound, bound, allow_nan=False, allow_infinity=False)
    return (
        st.tuples(coordinate, coordinate, coordinate)
        .map(lambda t: np.array(t, dtype=np.float64))
        .filter(lambda x: np.linalg.norm(x) >= min_norm)
    )


def level_set_states(system: MetriplecticSystem, level: float, radius: float = 1e3) -> st.SearchStrategy[Vector]:
    """States ``x`` with ``H(x) = level``: a random direction ``u``, then ``x = r u`` with
    ``H(r u) = level`` solved by bisection on ``0 < r <= radius``.

    Needs ``H(0) < level`` and H increasing along the ray up to its crossing
    (true for the catalogue); directions without a crossing are rejected by
    ``assume``.  ``H(x)`` matches ``level`` to a few ulp.
    """
    coordinate = st.floats(-1.0, 1.0, allow_nan=False)
    directions = st.tuples(coordinate, coordinate, coordinate).map(np.array).filter(lambda u: np.linalg.norm(u) >= 1e-3)
    return directions.map(lambda u: _on_ray(system, level, u / np.linalg.norm(u), radius))


def _on_ray(system, level, unit, radius):
    low, high = 0.0, radius
    assume(system.H(low * unit) < level < system.H(high * unit))
    for _ in range(200):
        middle = 0.5 * (low + high)
        if middle in (low, high):
            break
        if system.H(middle * unit) < level:
            low = middle
        else:
            high = middle
    return high * unit


def step_sizes(low: float = 1e-3, high: float = 0.5) -> st.SearchStrategy[float]:
    """Step sizes log-uniform in ``[low, high]``."""
    return st.floats(np.log(low), np.log(high)).map(np.exp)


def _coefficient(low=0.1, high=3.0):
    return st.floats(low, high, allow_nan=False)


def catalogue_systems(eps: st.SearchStrategy[float] = st.floats(0.0, 5.0)) -> st.SearchStrategy[MetriplecticSystem]:  # noqa: B008 (a strategy is immutable)
    """Every catalogue system with random parameters and random ``eps``."""
    rigid = st.builds(_catalogue.relaxing_rigid_body, _coefficient(), _coefficient(), _coefficient(), eps=eps)
    quartic = st.builds(
        _catalogue.quartic_rigid_body, _coefficient(), _coefficient(), _coefficient(), st.floats(0.0, 2.0), eps=eps
    )
    # coefficients on a grid of 0.1: tiny nonzero ones fail the constructor's finite-difference check
    polynomial = st.lists(st.integers(-20, 20).map(lambda k: k / 10), min_size=2, max_size=5)
    oscillator = st.builds(_catalogue.dissipative_oscillator, polynomial, eps=eps)
    degenerate = st.builds(_catalogue.degenerate_example, st.sampled_from([1, 2]), eps=eps)
    return st.one_of(rigid, quartic, oscillator, degenerate)


def catalogue_examples() -> list[MetriplecticSystem]:
    """One instance of every catalogue system with its default parameters (both degenerate examples)."""
    return [
        _catalogue.relaxing_rigid_body(),
        _catalogue.quartic_rigid_body(),
        _catalogue.dissipative_oscillator(),
        _catalogue.degenerate_example(1),
        _catalogue.degenerate_example(2),
    ]


def structure_preserving_methods() -> list[Integrator]:
    """Every integrator of the whole field (``geomint.integrators.INTEGRATORS``) that declares
    ``energy_exact`` and ``dissipative`` with default options, plus the compositions with
    ``monotone=True`` (sub-flow integrators such as exact Hamiltonian flows are parts of
    splittings, not integrators of the metriplectic field)."""
    from .integrators import Composition

    methods = [cls() for _, cls in sorted(INTEGRATORS.items())]
    methods += [cls(monotone=True) for cls in INTEGRATORS.values() if issubclass(cls, Composition)]
    return [m for m in methods if m.whole_field and m.energy_exact and m.dissipative]


# -- one step and its invariants ----------------------------------------------------------
def one_step(
    system: MetriplecticSystem, method: Integrator | str, x: npt.ArrayLike, h: float, allow_failure: bool = False
) -> Vector:
    """``x_{n+1}`` after one step of size ``h`` from ``x``.

    A failed step raises ``AssertionError``; with ``allow_failure=True`` it is
    rejected instead (``hypothesis.reject``), for domains that include steps
    far beyond the problem's time scale, which an implicit method may refuse.
    """
    h = _validate.real("h", h)
    if not (math.isfinite(h) and h != 0.0):
        raise ValueError(f"`h` must be finite and non-zero (negative: a step back); got {h!r}.")
    sol = solve(system, x, (0.0, h), abs(h), method=method)
    if allow_failure and not sol.success:  # a reported failure is allowed; a silent NaN is not
        assert sol.status in (-1, -2, -3) and "Step 1 " in sol.message and np.all(sol.x == x), sol.message
        reject()
    assert sol.success, sol.message
    assert np.all(np.isfinite(sol.x[-1])), f"non-finite state {sol.x[-1].tolist()} reported as success"
    return sol.x[-1]


def term_scale(
    value_old: float,
    value_new: float,
    gradient: npt.ArrayLike,
    x: npt.ArrayLike,
    base: float = 0.0,
) -> float:
    """The size of the terms of F at a step: ``max(|F(x)|, |F(x')|, |grad F(x)| |x|, base)``.

    Round-off in evaluating F is a few ulps of its largest term; ``|grad F||x|``
    measures the terms where they cancel (for homogeneous F of degree k it is
    k |F|); ``base`` the constant and linear terms, which it misses where they
    cancel the rest (``origin_terms``).
    """
    return max(abs(value_old), abs(value_new), float(np.hypot.reduce(gradient) * np.hypot.reduce(x)), base)


def origin_terms(system: MetriplecticSystem, name: Literal["H", "S"], x: npt.ArrayLike) -> float:
    """``|F(0)| + sum_i |d_i F(0) x_i|`` for F = ``name`` (``"H"`` or ``"S"``): the constant and linear
    terms of F at x (``H = |x - c|^2 / 2`` written out has terms ~ |c|^2 where H ~ 0); 0 for a term that is
    not finite at 0 (log |x| ...).  In R^3 and in R^n (the energy E of a ``GenericSystem`` for ``"H"``)."""
    if name not in ("H", "S"):
        raise ValueError(f"`name` must be 'H' or 'S'; got {name!r}.")
    x = np.asarray(x, dtype=float)
    zero = np.zeros(x.shape[-1])
    value, gradient = (system.H, system.grad_H) if name == "H" else (system.S, system.grad_S)
    try:
        with np.errstate(all="ignore"):
            terms = np.array([value(zero), *np.asarray(gradient(zero), dtype=float)], dtype=float)
    except Exception:  # noqa: BLE001 - singular at 0: no such terms to measure
        return 0.0
    terms[~np.isfinite(terms)] = 0.0
    return float(abs(terms[0]) + np.abs(terms[1:]) @ np.abs(x))


def assert_conserves_energy(system: MetriplecticSystem, x: Vector, x_new: Vector, ulps: float = 16) -> None:
    """``|H(x') - H(x)| <= ulps * eps * scale`` (see ``term_scale``)."""
    H0, H1 = system.H(x), system.H(x_new)
    tol = ulps * EPS * term_scale(H0, H1, system.grad_H(x), x, origin_terms(system, "H", x))
    assert abs(H1 - H0) <= tol, f"|dH| = {abs(H1 - H0):.3e} > {tol:.3e} ({ulps} ulp) from x = {x.tolist()}"


def assert_dissipates(system: MetriplecticSystem, x: Vector, x_new: Vector, ulps: float = 16) -> None:
    """S does not move against its direction beyond round-off: ``d (S(x') - S(x)) >= -ulps * eps * scale``,
    ``d = system.direction`` (-1: S never rises, the Fish form in R^3 and R^n; +1: the entropy of a
    ``GenericSystem`` never falls)."""
    S0, S1 = system.S(x), system.S(x_new)
    tol = ulps * EPS * term_scale(S0, S1, system.grad_S(x), x, origin_terms(system, "S", x))
    against = -system.direction * (S1 - S0)
    moved = "rose" if system.direction < 0 else "fell"
    assert against <= tol, f"S {moved} by {against:.3e} > {tol:.3e} ({ulps} ulp) from x = {x.tolist()}"


def assert_step_invariants(
    system: MetriplecticSystem, method: Integrator, x: Vector, h: float, ulps: float = 16, allow_failure: bool = False
) -> Vector:
    """One step from ``x``: H kept to ``ulps`` and S not raised beyond ``ulps`` (as declared).

    Checks only what ``method`` declares (``energy_exact``, ``dissipative``);
    returns the new state.  ``allow_failure``: see ``one_step``.
    """
    x_new = one_step(system, method, x, h, allow_failure)
    if method.energy_exact:
        assert_conserves_energy(system, x, x_new, ulps)
    if method.dissipative:
        assert_dissipates(system, x, x_new, ulps)
    return x_new
