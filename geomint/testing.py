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

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

from . import systems as _catalogue
from .solve import solve

EPS = np.finfo(np.float64).eps


# -- strategies -----------------------------------------------------------------------
def states(bound=2.0, min_norm=1e-2):
    """States in the box ``[-bound, bound]^3`` with ``|x| >= min_norm``, as float64 arrays."""
    coordinate = st.floats(-bound, bound, allow_nan=False, allow_infinity=False)
    return (
        st.tuples(coordinate, coordinate, coordinate)
        .map(lambda t: np.array(t, dtype=np.float64))
        .filter(lambda x: np.linalg.norm(x) >= min_norm)
    )


def step_sizes(low=1e-3, high=0.5):
    """Step sizes log-uniform in ``[low, high]``."""
    return st.floats(np.log(low), np.log(high)).map(np.exp)


def _coefficient(low=0.1, high=3.0):
    return st.floats(low, high, allow_nan=False)


def catalogue_systems(eps=st.floats(0.0, 5.0)):
    """Every catalogue system with random parameters and random ``eps``."""
    rigid = st.builds(_catalogue.relaxing_rigid_body, _coefficient(), _coefficient(), _coefficient(), eps=eps)
    quartic = st.builds(
        _catalogue.quartic_rigid_body, _coefficient(), _coefficient(), _coefficient(), st.floats(0.0, 2.0), eps=eps
    )
    polynomial = st.lists(st.floats(-2.0, 2.0), min_size=2, max_size=5)
    oscillator = st.builds(_catalogue.dissipative_oscillator, polynomial, eps=eps)
    degenerate = st.builds(_catalogue.degenerate_example, st.sampled_from([1, 2]), eps=eps)
    return st.one_of(rigid, quartic, oscillator, degenerate)


# -- one step and its invariants ----------------------------------------------------------
def one_step(system, method, x, h, allow_failure=False):
    """``x_{n+1}`` after one step of size ``h`` from ``x``.

    A failed step raises ``AssertionError``; with ``allow_failure=True`` it is
    rejected instead (``hypothesis.reject``), for domains that include steps
    far beyond the problem's time scale, which an implicit method may refuse.
    """
    sol = solve(system, x, (0.0, h), h, method=method)
    if allow_failure and not sol.success:
        reject()
    assert sol.success, sol.message
    return sol.x[-1]


def term_scale(value_old, value_new, gradient, x):
    """The size of the terms of F at a step: ``max(|F(x)|, |F(x')|, |grad F(x)| |x|)``.

    Round-off in evaluating F is a few ulps of its largest term; ``|grad F||x|``
    measures the terms where they cancel (for homogeneous F of degree k it is
    k |F|).
    """
    return max(abs(value_old), abs(value_new), float(np.hypot.reduce(gradient) * np.hypot.reduce(x)))


def assert_conserves_energy(system, x, x_new, ulps=16):
    """``|H(x') - H(x)| <= ulps * eps * scale`` (see ``term_scale``)."""
    H0, H1 = system.H(x), system.H(x_new)
    tol = ulps * EPS * term_scale(H0, H1, system.grad_H(x), x)
    assert abs(H1 - H0) <= tol, f"|dH| = {abs(H1 - H0):.3e} > {tol:.3e} ({ulps} ulp) from x = {x.tolist()}"


def assert_dissipates(system, x, x_new, ulps=16):
    """``S(x') - S(x) <= ulps * eps * scale``: S does not rise beyond round-off."""
    S0, S1 = system.S(x), system.S(x_new)
    tol = ulps * EPS * term_scale(S0, S1, system.grad_S(x), x)
    assert S1 - S0 <= tol, f"S rose by {S1 - S0:.3e} > {tol:.3e} ({ulps} ulp) from x = {x.tolist()}"


def assert_step_invariants(system, method, x, h, ulps=16, allow_failure=False):
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


# -- orders ---------------------------------------------------------------------------------
def observed_order(step_sizes, errors, floor=1e-13):
    """Least-squares slope of ``log error`` against ``log h``, round-off plateau excluded.

    Points with ``error <= floor`` (relative round-off level) are dropped, and
    so is everything on the small-h side of the first point where the error
    stops decreasing.  Needs at least three points left.
    """
    h = np.asarray(step_sizes, dtype=float)
    e = np.asarray(errors, dtype=float)
    order = np.argsort(h)[::-1]
    h, e = h[order], e[order]
    keep = [0]
    for i in range(1, len(h)):
        if e[i] <= floor or e[i] >= e[keep[-1]]:
            break
        keep.append(i)
    if len(keep) < 3:
        raise ValueError(f"need >= 3 points above the round-off plateau; errors = {e.tolist()}")
    slope, _ = np.polyfit(np.log(h[keep]), np.log(e[keep]), 1)
    return float(slope)
