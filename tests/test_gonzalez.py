"""The Gonzalez discrete-gradient integrator: exact energy and dissipation, per step."""

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

import geomint
import geomint.testing as gt

EPS = np.finfo(float).eps


@given(system=gt.catalogue_systems(), x=gt.states(), h=gt.step_sizes(1e-3, 0.5))
def test_each_step_keeps_H_and_does_not_raise_S(system, x, h):
    """Every accepted step, over the whole domain; stiff corners (h far beyond the
    time scale 1 / (eps |grad H|^2 ...)) may be refused, and are reported as failed."""
    gt.assert_step_invariants(system, geomint.Gonzalez(), x, h, ulps=16, allow_failure=True)


@given(system=gt.catalogue_systems(eps=st.floats(0.0, 1.0)), x=gt.states(bound=1.0), h=gt.step_sizes(1e-3, 0.05))
def test_steps_on_the_time_scale_always_succeed(system, x, h):
    gt.assert_step_invariants(system, geomint.Gonzalez(), x, h, ulps=16)


@given(system=gt.catalogue_systems(), x=gt.states(), h=gt.step_sizes(1e-3, 0.5))
@example(
    system=geomint.systems.quartic_rigid_body(
        0.19960137114540488, 0.1, 2.00001, 1.6545766467710967, eps=0.12051735129147259
    ),
    x=np.array([0.0, 1.5, 0.483098552047482]),
    h=0.0010000000000000002,
)
def test_discrete_dissipation_identity(system, x, h):
    """S(x') - S(x) = -h eps |dgH x dgS|^2 + dgS . r to round-off, r = x' - x - h F(x, x') the residual the
    Newton solve stopped at (within sqrt(eps) of the state where it stalls, docs/theory.md: S still does not
    rise and H is still kept, but the identity moves by dgS . r; found by hypothesis at 89 ulp, residual 1e-11)."""
    x_new = gt.one_step(system, geomint.Gonzalez(), x, h, allow_failure=True)
    dg_h, dg_s, axial = geomint.Gonzalez().discrete_gradients(system, x, x_new)
    residual = (x_new - x) - h * (np.cross(dg_h, axial) + system.eps * np.cross(dg_h, np.cross(dg_h, dg_s)))
    assert np.max(np.abs(residual)) <= np.sqrt(EPS) * max(np.max(np.abs(x_new)), np.max(np.abs(x_new - x)))
    predicted = -h * system.eps * np.sum(np.cross(dg_h, dg_s) ** 2)
    change = system.S(x_new) - system.S(x)
    scale = gt.term_scale(system.S(x), system.S(x_new), system.grad_S(x), x) + abs(predicted)
    assert abs(change - predicted - dg_s @ residual) <= 64 * EPS * scale


@given(system=gt.catalogue_systems(), x=gt.states(), x_new=gt.states())
def test_discrete_gradients_satisfy_the_mean_value_property(system, x, x_new):
    dg_h, dg_s, axial = geomint.Gonzalez().discrete_gradients(system, x, x_new)
    dx = x_new - x
    for F, grad, dg in ((system.H, system.grad_H, dg_h), (system.S, system.grad_S, dg_s)):
        scale = gt.term_scale(F(x), F(x_new), grad(x), x) + np.abs(dg) @ np.abs(dx)
        assert abs(dg @ dx - (F(x_new) - F(x))) <= 16 * EPS * scale
    assert np.linalg.norm(np.cross(axial, dg_s)) <= 8 * EPS * np.linalg.norm(axial) * np.linalg.norm(dg_s)


def test_the_gonzalez_correction_is_applied():
    """On non-quadratic H the midpoint gradient is no discrete gradient: dropping the
    correction (the scheme silently becomes the implicit midpoint rule) breaks this."""
    system = geomint.systems.quartic_rigid_body(k=1.0)
    x, x_new = np.array([0.9, 0.4, -0.3]), np.array([0.2, 1.1, 0.5])
    dg_h, _, _ = geomint.Gonzalez().discrete_gradients(system, x, x_new)
    midpoint = system.grad_H((x + x_new) / 2)
    change = system.H(x_new) - system.H(x)
    assert abs(midpoint @ (x_new - x) - change) > 1e-3  # the correction matters here ...
    assert abs(dg_h @ (x_new - x) - change) <= 16 * EPS * abs(system.H(x))  # ... and is there
    sol = geomint.solve(system, [0.9, 0.4, -0.3], (0, 20), 0.5)
    assert sol.success and sol.energy_error <= 64 * EPS


def test_gonzalez_reduces_to_implicit_midpoint_on_quadratic_systems():
    system = geomint.systems.relaxing_rigid_body(eps=0.3)
    x = np.array([0.4, 0.5, 0.7])
    x_new = gt.one_step(system, geomint.Gonzalez(), x, 0.2)
    residual = x_new - x - 0.2 * system.xi((x + x_new) / 2)
    assert np.max(np.abs(residual)) <= 64 * EPS


@pytest.mark.parametrize("eps", [0.0, 0.1])
def test_million_steps_keep_energy_to_round_off(eps):
    """REFERENCES.md R2, h = 0.05, 10^6 steps: max |H - H0| / |H0| <= 1e-13 (RK4 beside it)."""
    system = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=eps)
    x0 = [np.cos(1.1), 0.0, np.sin(1.1)]
    sol = geomint.solve(system, x0, (0.0, 50_000.0), 0.05, save_every=100)
    rk4 = geomint.solve(system, x0, (0.0, 50_000.0), 0.05, method="rk4", save_every=100)
    print(f"eps={eps}: Gonzalez drift {sol.energy_error:.2e}, RK4 drift {rk4.energy_error:.2e}")
    assert sol.success and sol.n_steps == 1_000_000
    assert sol.energy_error <= 1e-13
    assert sol.S_rises == 0
    assert rk4.energy_error > 1e3 * sol.energy_error  # the baseline does drift


def test_newton_failure_is_reported_with_the_step_and_keeps_the_states():
    system = geomint.systems.quartic_rigid_body(k=1.0, eps=1.0)
    sol = geomint.solve(system, [0.9, 0.4, -0.3], (0.0, 10.0), 0.3, method=geomint.Gonzalez(max_newton_iter=1))
    assert not sol.success and sol.status == -1
    assert sol.failed_step == 1
    assert "Step 1 (t = 0 -> 0.3) failed: the Newton iteration did not converge" in sol.message
    assert "max_newton_iter" in sol.message
    np.testing.assert_array_equal(sol.x, [[0.9, 0.4, -0.3]])


def test_failure_after_some_steps_keeps_everything_before_it():
    """A step far beyond the time scale on the non-quadratic system: Newton cannot follow."""
    system = geomint.systems.quartic_rigid_body(k=2.0, eps=5.0)
    sol = geomint.solve(system, [1.5, -1.2, 0.9], (0.0, 400.0), 20.0, method=geomint.Gonzalez(max_newton_iter=8))
    assert not sol.success
    assert sol.status in (-1, -2)
    assert np.all(np.isfinite(sol.x)) and np.all(np.isfinite(sol.H)) and np.all(np.isfinite(sol.S))
    k = sol.failed_step
    assert f"Step {k} " in sol.message
    assert sol.n_steps == k - 1 and sol.t[-1] == pytest.approx(20.0 * (k - 1))
    assert np.all(np.abs(sol.H - sol.H[0]) <= 64 * EPS * abs(sol.H[0]))  # what was kept is exact


@pytest.mark.parametrize("eps", [0.1, 0.5, 1.0])
def test_relaxation_into_the_stable_pole_never_stalls_newton(eps):
    """Regression: near the attracting pole the increments are tiny and the Newton
    corrections bounce on the round-off floor; that must be recognised, not fail."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=eps)
    sol = geomint.solve(body, [0.00483841, -0.00917336, 0.92885403], (0.0, 200.0), 0.02)
    assert sol.success, sol.message
    assert sol.energy_error <= 16 * EPS and sol.S_rises == 0
    assert sol.S[-1] == pytest.approx(sol.H[0] / 1.5, rel=1e-12)  # S_inf = H0 / c
