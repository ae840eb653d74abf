"""Every discrete-gradient integrator: per-step invariants on every catalogue system, declared orders, traits."""

import numpy as np
import pytest
from hypothesis import given
from numba import njit

import geomint
import geomint.testing as gt

METHODS = [geomint.Gonzalez(), geomint.ItohAbe(), geomint.SymmetrizedItohAbe(), geomint.AVF(), geomint.DampedGonzalez()]


@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.name)
@given(system=gt.catalogue_systems(), x=gt.states(), h=gt.step_sizes())
def test_step_invariants_on_every_catalogue_system(method, system, x, h):
    """One step: H kept to 16 ulp of its terms, S not raised beyond 16 ulp (as every method declares)."""
    assert method.energy_exact and method.dissipative
    gt.assert_step_invariants(system, method, x, h, allow_failure=True)


@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.name)
@given(x=gt.level_set_states(geomint.systems.quartic_rigid_body(eps=2.0), level=0.8), h=gt.step_sizes(1e-2, 1.0))
def test_step_invariants_on_a_level_set(method, x, h):
    """Steps from states on ``H = 0.8`` of the quartic body stay on it to 16 ulp."""
    system = geomint.systems.quartic_rigid_body(eps=2.0)
    assert abs(system.H(x) - 0.8) <= 8 * np.finfo(float).eps
    gt.assert_step_invariants(system, method, x, h, allow_failure=True)


@njit(cache=True)
def _minus_identity(m, p):
    return (-m[0], -m[1], -m[2])


def _time_reversed(body):
    """The same H and S with ``J -> -J``: the Hamiltonian field reversed."""
    f = body.functions
    return geomint.MetriplecticSystem(
        H=f.H, grad_H=f.grad_H, S=f.S, grad_S=f.grad_S, J=_minus_identity, eps=0.0, params=body.params
    )


QUARTIC = geomint.systems.quartic_rigid_body(0.5, 1.0, 1.5, k=0.5, eps=0.5)
X0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])
T_END = 2.0
STEPS = [0.01, 0.005, 0.0025, 0.00125, 0.000625]


@pytest.fixture(scope="module")
def reference():
    return gt.reference_solution(QUARTIC, X0, T_END)


@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.name)
def test_measured_order_matches_declared(method, reference):
    """Slope of the final-state error against h on the non-quadratic body, within 0.1 of ``order``."""
    order, errors = gt.measured_order(QUARTIC, method, X0, T_END, STEPS, reference=reference)
    assert abs(order - method.order) <= 0.1, (order, errors)


@pytest.mark.parametrize("method", [m for m in METHODS if m.symmetric], ids=lambda m: m.name)
def test_symmetric_methods_are_time_reversible(method):
    """A step forward then a step of the adjoint (time-reversed field) returns to the start."""
    body = geomint.systems.quartic_rigid_body(eps=0.0)
    x = np.array([0.3, 0.8, -0.5])
    forward = gt.one_step(body, method, x, 0.2)
    back = gt.one_step(_time_reversed(body), method, forward, 0.2)
    np.testing.assert_allclose(back, x, rtol=0, atol=1e-13)


def test_itoh_abe_is_not_time_reversible():
    body = geomint.systems.quartic_rigid_body(eps=0.0)
    x = np.array([0.3, 0.8, -0.5])
    back = gt.one_step(_time_reversed(body), geomint.ItohAbe(), gt.one_step(body, geomint.ItohAbe(), x, 0.2), 0.2)
    assert np.max(np.abs(back - x)) > 1e-6
