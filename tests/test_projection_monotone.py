"""Projection onto H = H0 that never raises S, and the monotone safeguard of compositions."""

import numpy as np
import pytest

import geomint
import geomint.testing as gt
from geomint.integrators import S_rise_statistics

EPS = np.finfo(float).eps
X0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])  # REFERENCES.md R2


def _rk4_projected_run(n_steps, eps):
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=eps)
    return geomint.solve(body, X0, (0.0, 0.05 * n_steps), 0.05, method=geomint.Projected(), save_every=1)


@pytest.mark.parametrize("eps", [0.0, 1.0])
def test_projected_rk4_keeps_H_to_4_ulp_and_never_raises_S(eps):
    sol = _rk4_projected_run(20_000, eps)
    assert sol.success
    assert sol.energy_error <= 4 * EPS, sol.energy_error / EPS
    assert sol.S_rises == 0
    plain = geomint.solve(geomint.systems.relaxing_rigid_body(eps=eps), X0, (0.0, 1000.0), 0.05, method="rk4")
    assert plain.energy_error > 1e3 * EPS  # the projection is doing the work


@pytest.mark.slow
@pytest.mark.parametrize("eps", [0.0, 1.0])
def test_projected_rk4_million_steps(eps):
    sol = _rk4_projected_run(1_000_000, eps)
    print(f"eps={eps}: max |H-H0|/|H0| = {sol.energy_error / EPS:.2f} ulp, S rises: {sol.S_rises}")
    assert sol.success and sol.n_steps == 1_000_000
    assert sol.energy_error <= 4 * EPS
    assert sol.S_rises == 0


def test_the_S_constraint_of_the_projection_is_active_when_the_method_raises_S():
    """The free rigid body: RK4 makes |m| oscillate; the projection keeps S from rising."""
    body = geomint.systems.relaxing_rigid_body(eps=0.0)
    raw = geomint.solve(body, X0, (0.0, 100.0), 0.05, method="rk4")
    projected = geomint.solve(body, X0, (0.0, 100.0), 0.05, method=geomint.Projected())
    assert raw.S_rises > 100
    assert projected.success and projected.S_rises == 0 and projected.energy_error <= 4 * EPS


@pytest.mark.parametrize(
    "method, order",
    [
        (geomint.Projected(), 4),
        (geomint.Projected(geomint.Gonzalez(), symmetric=True), 2),
        (geomint.Projected(geomint.Yoshida4(), symmetric=True), 4),
    ],
)
def test_projection_keeps_the_order_of_the_method(method, order):
    """Free rigid body (R1), reference: the exact flow."""
    body = geomint.systems.relaxing_rigid_body(eps=0.0)
    exact = geomint.reference.rigid_body_exact(0.5, 1.0, 1.5, X0, 2.0)
    hs = 2.0 / np.array([16, 23, 32, 45, 64])
    errors = [
        np.max(np.abs(geomint.solve(body, X0, (0.0, 2.0), h, method=method, save_every=None).x_final - exact))
        for h in hs
    ]
    assert abs(gt.observed_order(hs, errors) - order) <= 0.15


R2_BASE = geomint.Strang(geomint.RigidBodyFlow(), geomint.Gonzalez())


@pytest.mark.parametrize("scheme", ["yoshida4", "yoshida6", "kahan_li8"])
def test_negative_gammas_raise_S_in_sub_steps_and_monotone_stops_full_step_rises(scheme):
    """R2 at eps = 1, h = 0.01, 5000 steps; rises counted strictly (0 ulp) and beyond 16 ulp."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=1.0)
    free = S_rise_statistics(body, geomint.Composition(R2_BASE, scheme), X0, 0.01, 5000, ulps=0)
    safe = S_rise_statistics(body, geomint.Composition(R2_BASE, scheme, monotone=True), X0, 0.01, 5000, ulps=0)
    print(scheme, "free:", free, "monotone:", safe)
    assert free["sub_step_rises"] > 0  # the backward gradient sub-steps
    assert free["full_step_rises"] > 0  # near the equilibrium, by round-off
    assert S_rise_statistics(body, geomint.Composition(R2_BASE, scheme), X0, 0.01, 5000)["full_step_rises"] == 0
    assert safe["safeguard_fired"] > 0 and safe["status"] == 0
    # what remains is the fallback's own round-off (Gonzalez lowers S up to round-off)
    assert (
        S_rise_statistics(body, geomint.Composition(R2_BASE, scheme, monotone=True), X0, 0.01, 5000)["full_step_rises"]
        == 0
    )


def test_the_monotone_safeguard_costs_no_accuracy_where_it_does_not_fire():
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=1.0)
    for scheme in ("yoshida4", "yoshida6"):
        free, safe = (
            geomint.solve(
                body, X0, (0.0, 5.0), 0.1, method=geomint.Composition(R2_BASE, scheme, monotone=m), save_every=None
            )
            for m in (False, True)
        )
        assert np.array_equal(free.x_final, safe.x_final)


@pytest.mark.slow
@pytest.mark.parametrize("scheme", ["yoshida4", "yoshida6"])
def test_monotone_million_steps_never_raise_S(scheme):
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=1.0)
    method = geomint.Composition(R2_BASE, scheme, monotone=True)
    sol = geomint.solve(body, X0, (0.0, 0.01 * 1_000_000), 0.01, method=method, save_every=1)
    stats = S_rise_statistics(body, method, X0, 0.01, 1_000_000, ulps=0)
    print(scheme, stats, "energy error", sol.energy_error)
    assert sol.success and sol.n_steps == 1_000_000
    assert sol.S_rises == 0  # beyond 16 ulp, as Solution counts them


#: no full step of the monotone composition raises S by more than round-off: the S-change of moving the state by
#: an ulp, one ulp of the terms of S (``gt.term_scale``; on the bodies below they are 2-3 times S itself)
MONOTONE_ULPS = 1.25


def _worst_rise(system, sol, relative=False):
    """The largest rise of S between saved states in ulps of the terms of S at either end (``relative``: of the
    larger |S| itself, inf from S = 0), and the step where it happened."""
    worst, at = 0.0, 0
    for k in range(len(sol.t) - 1):
        rise = sol.S[k + 1] - sol.S[k]
        if not rise > 0.0:
            continue
        if relative:
            scale = max(abs(sol.S[k]), abs(sol.S[k + 1]))
        else:
            scale = max(
                gt.term_scale(sol.S[k], sol.S[k + 1], system.grad_S(x), x, gt.origin_terms(system, "S", x))
                for x in sol.x[k : k + 2]
            )
        ulps = rise / (EPS * scale) if scale > 0.0 else np.inf
        if ulps > worst:
            worst, at = ulps, k + 1
    return worst, at


def test_the_monotone_safeguard_keeps_S_from_rising_in_the_tail_of_the_degenerate_example():
    """Example 2 at eps = 3 from its pole (0, 0, 1): z decays to ~1e-55 (S ~ 1e-110) before it is flushed to 0.
    There the safeguard's Gonzalez fallback accepted roots at which S had risen by up to 4.5e15 ulps of itself
    (S 6e-115 -> 2e-112 at step 756, 1.8e-111 -> 2.3e-111 at step 561): the Newton iteration judged the corrected
    iterate against the terms of S at the uncorrected one, whose z was 1e9 times larger.  (The terms of S are 2 S
    here; relative to S because grad S . x would mix in x ~ 1.)"""
    example = geomint.systems.degenerate_example(2, eps=3.0)
    method = geomint.Yoshida4(geomint.Gonzalez(), monotone=True)
    sol = geomint.solve(example, [0.0, 0.0, 1.0], (0.0, 60.0), 0.05, method=method)
    assert sol.success, sol.message
    assert np.any((sol.S > 0) & (sol.S < 1e-100))  # the run reached the tail
    worst, at = _worst_rise(example, sol, relative=True)
    assert worst <= 2 * MONOTONE_ULPS, f"S rose by {worst:.3g} ulps of S at step {at} (S = {sol.S[at - 1]:.3g})"


SADDLE_STARTS = {
    # 1e-12 off the relaxing body's intermediate axis (a saddle of S on the level set) into its stable pole
    "rigid body": (geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=1.0), [0.0, 1.0, 1e-12], 0.05, 70.0),
    # a start on the quartic body, whose terms of S are |x|^2 + |x|^4, 2.6 S at the pole reached
    "quartic body": (
        geomint.systems.quartic_rigid_body(eps=0.2),
        [-0.3250850963931098, -0.00734246278963139, -0.9456562633130843],
        0.1,
        30.0,
    ),
}


@pytest.mark.parametrize("case", sorted(SADDLE_STARTS))
def test_the_monotone_safeguard_keeps_S_from_rising_at_the_pole(case):
    """Steps pulled back onto H(x0) at rest at the stable pole raised S by up to 1.88 ulps of its terms (3.75 ulps
    of S, 5 units in its last place: rigid body, step 1275) and 1.97 (quartic body, step 215): H and S are locked
    there (grad S || grad H), and the pull back restored the few ulps H had lost within the loose allowance of a
    projection (2 ulps of |grad S|_inf |x|_inf)."""
    system, x0, h, t_end = SADDLE_STARTS[case]
    method = geomint.Yoshida4(geomint.Gonzalez(), monotone=True)
    sol = geomint.solve(system, x0, (0.0, t_end), h, method=method)
    assert sol.success, sol.message
    assert sol.energy_error <= 16 * EPS
    worst, at = _worst_rise(system, sol)
    assert worst <= MONOTONE_ULPS, f"S rose by {worst:.3g} ulps of its terms at step {at} (S = {sol.S[at]:.17g})"
