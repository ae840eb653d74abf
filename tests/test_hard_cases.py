"""The hard cases of issue 3, one named test each, over every structure-preserving integrator.

Each test asserts what theory says (docs/hard_cases.md); where a method has a
documented limitation the test asserts the limitation itself, so a change in
behaviour fails here and the documentation has to follow.
"""

import numpy as np
import pytest

import geomint
import geomint.testing as gt

EPS = np.finfo(float).eps
METHODS = gt.structure_preserving_methods()
X0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])  # REFERENCES.md R1/R2
each_method = pytest.mark.parametrize("method", METHODS, ids=lambda m: m.name)


def _exact_run(sol):
    """No NaN; every saved step kept H to 64 ulp of H0 (16 ulp of terms up to 4 |H|) and did not raise S
    beyond round-off; the whole run drifted less than 1e-13."""
    assert np.all(np.isfinite(sol.x)) and np.all(np.isfinite(sol.H)) and np.all(np.isfinite(sol.S))
    if len(sol.H) > 1:
        assert np.max(np.abs(np.diff(sol.H))) <= 64 * EPS * abs(sol.H[0]), np.max(np.abs(np.diff(sol.H)))
    assert sol.energy_error <= 1e-13, sol.energy_error
    assert sol.S_rises == 0


@each_method
@pytest.mark.parametrize("system", [s for s in gt.catalogue_examples()], ids=lambda s: s.name)
def test_origin_stays_fixed(method, system):
    """grad H = 0 at the origin of every catalogue system but Example 2: the state stays exactly at 0."""
    if system.name == "degenerate_example_2":
        pytest.skip("grad H = (0, -1, 0) at the origin of Example 2: not a critical point")
    sol = geomint.solve(system, np.zeros(3), (0.0, 5.0), 0.1, method=method)
    assert sol.success, sol.message
    assert np.all(sol.x == 0.0)


@each_method
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_rigid_body_axes_stay_fixed(method, axis):
    """Every point on a principal axis is an equilibrium (grad H || grad S || J): no motion at all."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=1.0)
    x0 = np.zeros(3)
    x0[axis] = -0.8
    sol = geomint.solve(body, x0, (0.0, 10.0), 0.1, method=method)
    assert sol.success, sol.message
    assert np.all(sol.x == x0)


@each_method
def test_oscillator_where_grad_S_vanishes(method):
    """Oscillator, S = z^2/2, on z = 0: grad S = 0, dissipation off; z stays exactly 0 and |x| is kept."""
    oscillator = geomint.systems.dissipative_oscillator((0.0, 0.0, 0.5), eps=10.0)
    sol = geomint.solve(oscillator, [0.6, -0.8, 0.0], (0.0, 20.0), 0.1, method=method)
    assert sol.success, sol.message
    assert np.all(sol.x[:, 2] == 0.0)
    _exact_run(sol)
    assert np.ptp(np.arctan2(sol.x[:, 1], sol.x[:, 0])) > 3.0  # it rotates


@each_method
def test_example_1_great_circle_on_y0_is_invariant(method):
    """Paper Example 1 on y = 0 (P = 0): the great circle stays invariant and flows to (r0, 0, 0)."""
    example = geomint.systems.degenerate_example(1, eps=1.0)
    x0 = np.array([0.6, 0.0, 0.8])
    sol = geomint.solve(example, x0, (0.0, 40.0), 0.1, method=method)
    assert sol.success, sol.message
    _exact_run(sol)
    assert np.max(np.abs(sol.x[:, 1])) <= 1e-14
    np.testing.assert_allclose(sol.x_final, [1.0, 0.0, 0.0], atol=1e-8)


@each_method
def test_example_2_leaves_y0_except_at_z0(method):
    """Paper Example 2: from y = 0 with z != 0 the state leaves the plane; with z = 0 it is an equilibrium."""
    example = geomint.systems.degenerate_example(2, eps=1.0)
    sol = geomint.solve(example, [0.6, 0.0, 0.8], (0.0, 2.0), 0.05, method=method)
    assert sol.success, sol.message
    _exact_run(sol)
    assert np.max(np.abs(sol.x[:, 1])) > 1e-2
    still = geomint.solve(example, [0.6, 0.0, 0.0], (0.0, 2.0), 0.05, method=method)
    assert np.all(still.x == [0.6, 0.0, 0.0])


@each_method
def test_tiny_steps(method):
    """h = 1e-12: exact at round-off, no NaN, and the state moves by h xi (no stall at the switch)."""
    quartic = geomint.systems.quartic_rigid_body(eps=1.0)
    sol = geomint.solve(quartic, X0, (0.0, 1e-10), 1e-12, method=method)
    assert sol.success, sol.message
    _exact_run(sol)
    expected = X0 + 1e-10 * quartic.xi(X0)
    # a projection may move each of the 100 states by round-off: 4 ulp a step
    np.testing.assert_allclose(sol.x_final - X0, expected - X0, rtol=1e-6, atol=100 * 4 * EPS)


@each_method
@pytest.mark.parametrize("h", [1.0, 10.0, 100.0])
@pytest.mark.parametrize("eps", [1.0, 1e3, 1e6])
def test_huge_steps_and_stiff_dissipation(method, h, eps):
    """Each step is exact (H to round-off, S not rising) or the run stops with a status naming the step."""
    body = geomint.systems.quartic_rigid_body(eps=eps)
    sol = geomint.solve(body, X0, (0.0, 20 * h), h, method=method)
    _exact_run(sol)
    if not sol.success:
        assert sol.status in (-1, -2, -3)
        assert f"Step {sol.failed_step} " in sol.message and "are kept" in sol.message
        assert sol.n_steps == sol.failed_step - 1


#: Midpoint-type methods reflect the fast dissipative mode: with h eps = 100
#: they cannot get within 1e-8 of S_inf by t = 10 (docs/hard_cases.md); so do
#: the splittings built on them.
STALLS = {"gonzalez", "itoh_abe", "symmetrized_itoh_abe", "avf", "lie", "strang"}
#: Compositions above order 2 take backward sub-steps: on the stiff gradient flow
#: (h eps = 100) their implicit-midpoint sub-step has no solution near x and the
#: run stops at step 1 with status -1; projected RK4 is explicit and overflows
#: (status -2).  Both are reported failures, never a wrong state.
REFUSES_STIFF = {"yoshida4", "suzuki4", "yoshida6", "kahan_li6", "suzuki_umeno8", "kahan_li8", "projected"}


@each_method
def test_stiff_relaxation(method):
    """Relaxing body, eps = 1e3, h = 0.1: S reaches S_inf = H0/c within 1e-8 by t = 10, or (a documented
    limitation) stays above it while decreasing monotonically and keeping H exactly."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=1e3)
    sol = geomint.solve(body, X0, (0.0, 10.0), 0.1, method=method)
    if method.name in REFUSES_STIFF:
        assert not sol.success and sol.status in (-1, -2, -3), f"{method.name} now runs: update REFUSES_STIFF and docs"
        assert f"Step {sol.failed_step} " in sol.message
        _exact_run(sol)
        return
    assert sol.success, sol.message
    _exact_run(sol)
    gap = sol.S[-1] - body.H(X0) / 1.5
    assert gap >= -64 * EPS
    if method.name in STALLS:
        assert gap > 1e-6, f"{method.name} now relaxes (gap {gap:.2e}): update STALLS and docs/hard_cases.md"
    else:
        assert gap <= 1e-8


#: method and start with which the stiff relaxation (eps = 1e3, h = 0.1) once raised S by 5-6 units in the last
#: place of S (3.2-3.9 ulps of S) when the state came to rest at the pole
STIFF_AT_REST = {
    "damped, saddle": (geomint.DampedGonzalez(), [0.0, 1.0, 1e-12]),
    "damped, below": (geomint.DampedGonzalez(), [0.8969774524078379, 0.0594974703378604, -0.4380542214102498]),
    "lie, below": (
        geomint.Lie(geomint.Gonzalez(), geomint.DampedGonzalez()),
        [0.8969774524078379, 0.0594974703378604, -0.4380542214102498],
    ),
    "lie, above": (
        geomint.Lie(geomint.Gonzalez(), geomint.DampedGonzalez()),
        [-0.165771813920267, 0.7783637317188347, 0.6055324985946785],
    ),
}


@pytest.mark.parametrize("case", sorted(STIFF_AT_REST))
def test_stiff_relaxation_does_not_raise_S_at_rest(case):
    """The methods that do relax the stiff body: S never rises by more than round-off, 1.25 ulps of its terms
    (|x|^2, 2 S), also when the state has come to rest at the pole with H a few ulps below H(x0).  There H and S
    are locked (grad S || grad H, H0 / c is the least S on H = H0): restoring H(x0) raises S as much.
    DampedGonzalez's step accepted the root that did (1.88 ulps of the terms, the saddle start, step 29; 1.62
    from below, step 29), and Lie's pull back onto H(x0) moved the state along grad H within the loose allowance
    of a projection (1.92, the start above, step 28; 1.62 from below)."""
    method, x0 = STIFF_AT_REST[case]
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=1e3)
    sol = geomint.solve(body, x0, (0.0, 30.0), 0.1, method=method)
    assert sol.success, sol.message
    _exact_run(sol)
    terms = np.sum(sol.x * sol.x, axis=1)  # sum_i |x_i dS/dx_i|
    rise = np.diff(sol.S) / (EPS * np.maximum(terms[:-1], terms[1:]))
    assert np.max(rise) <= 1.25, f"S rose by {np.max(rise):.3g} ulps of its terms at step {np.argmax(rise) + 1}"
    np.testing.assert_allclose(sol.x_final, [0.0, 0.0, np.sign(x0[2]) * np.sqrt(2 * body.H(x0) / 1.5)], atol=1e-8)


@each_method
def test_equal_coefficients_circle_of_equilibria(method):
    """b = c: every point of the circle {x = 0} is an equilibrium: no motion beyond round-off, no drift.

    (The field there is zero only up to the rounding of ``b y z - c z y``: the state moves by an ulp.)"""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.5, 1.5, eps=1.0)
    x0 = np.array([0.0, 0.6, 0.8])
    sol = geomint.solve(body, x0, (0.0, 50.0), 0.1, method=method)
    assert sol.success, sol.message
    assert np.max(np.abs(sol.x - x0)) <= 4 * EPS


@each_method
def test_near_equal_coefficients(method):
    """b = c (1 - 1e-12): the motion along the near-circle is as slow as theory says (~1e-12 per unit time)."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.5 * (1 - 1e-12), 1.5, eps=1.0)
    x0 = np.array([0.0, 0.6, 0.8])
    sol = geomint.solve(body, x0, (0.0, 50.0), 0.1, method=method)
    assert sol.success, sol.message
    _exact_run(sol)
    assert np.max(np.abs(sol.x - x0)) <= 1e-9
    assert sol.x_final[2] >= x0[2]  # towards the axis of the largest coefficient


@each_method
@pytest.mark.parametrize("axis", [0, 1])
def test_unstable_equilibria_stay_put(method, axis):
    """Exactly on the smallest or intermediate axis (unstable): the state does not move."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.5)
    x0 = np.zeros(3)
    x0[axis] = 1.0
    sol = geomint.solve(body, x0, (0.0, 50.0), 0.1, method=method)
    assert np.all(sol.x == x0)


@each_method
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_leaving_the_intermediate_axis(method, sign):
    """1e-12 off the intermediate axis in z: the state leaves and settles on the z axis with the sign of z0."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.5)
    x0 = np.array([0.0, 1.0, sign * 1e-12])
    sol = geomint.solve(body, x0, (0.0, 200.0), 0.1, method=method)
    assert sol.success, sol.message
    _exact_run(sol)
    r_inf = np.sqrt(2.0 * body.H(x0) / 1.5)
    np.testing.assert_allclose(sol.x_final, [0.0, 0.0, sign * r_inf], atol=1e-8)


@each_method
@pytest.mark.parametrize("power", [-498, 332], ids=["1e-150", "1e+100"])
def test_scaled_states(method, power):
    """x -> lam x, h -> h/lam, eps -> eps/lam, t -> t/lam maps the relaxing body onto itself; with lam a
    power of two (2^-498 ~ 1e-150, 2^332 ~ 1e100) the scaled run is lam times the unscaled one to round-off."""
    lam = 2.0**power
    x0 = np.array([0.6, 0.0, 0.8])
    base = geomint.solve(geomint.systems.relaxing_rigid_body(eps=0.5), x0, (0.0, 5.0), 0.05, method=method)
    scaled = geomint.solve(
        geomint.systems.relaxing_rigid_body(eps=0.5 / lam), lam * x0, (0.0, 5.0 / lam), 0.05 / lam, method=method
    )
    assert scaled.success, scaled.message
    assert np.all(np.isfinite(scaled.x))
    np.testing.assert_allclose(scaled.x / lam, base.x, rtol=0, atol=1e-13)


@each_method
def test_decay_into_subnormals(method):
    """Oscillator, S = z^2/2: z decays like exp(-t); it is flushed to exactly 0 before reaching the
    subnormal range (no ~10x slowdown; cost ratio in docs/hard_cases.md), exactly conserving H."""
    oscillator = geomint.systems.dissipative_oscillator((0.0, 0.0, 0.5), eps=1.0)
    sol = geomint.solve(oscillator, [0.6, 0.0, 0.8], (0.0, 800.0), 0.1, method=method, save_every=10)
    assert sol.success, sol.message
    _exact_run(sol)
    z = np.abs(sol.x[:, 2])
    assert z[-1] == 0.0
    assert not np.any((z > 0) & (z < np.finfo(float).tiny))


@pytest.mark.slow
@pytest.mark.parametrize(
    "method", [m for m in METHODS if isinstance(m, geomint.integrators.DiscreteGradient)], ids=lambda m: m.name
)
def test_ten_million_steps_energy_at_round_off(method):
    """10^7 steps, relaxing body (0.5, 1, 1.5), eps = 0.1, h = 0.05: max |H - H0|/|H0| <= 1e-14.

    Every discrete-gradient method (the splittings and compositions run 10^6 steps in
    tests/test_projection_monotone.py; 10^7 of their 3 to 17 sub-steps would take minutes each)."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
    sol = geomint.solve(body, X0, (0.0, 5e5), 0.05, method=method, save_every=100)
    assert sol.success and sol.n_steps == 10**7
    assert sol.energy_error <= 1e-14, sol.energy_error


DISCRETE_GRADIENTS = [m for m in METHODS if isinstance(m, geomint.integrators.DiscreteGradient)]
FREE_BODIES = {
    "rigid body": geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.0),
    "quartic body": geomint.systems.quartic_rigid_body(eps=0.0),
}


def _casimir_drift(sol, every):
    """``(max |S - S0| / S0, the drift of S / S0 per step fitted by least squares)`` over the saved states."""
    drift = (sol.S - sol.S[0]) / sol.S[0]
    return float(np.max(np.abs(drift))), float(np.polyfit(every * np.arange(len(drift)), drift, 1)[0])


@pytest.mark.parametrize("body", sorted(FREE_BODIES))
@pytest.mark.parametrize("method", DISCRETE_GRADIENTS, ids=lambda m: m.name)
def test_the_casimir_of_a_free_body_does_not_drift(method, body):
    """eps = 0: S is conserved as H is; 10^5 steps, h = 0.05.  Each step kept S(x_n), not S(x0), so its
    rounding accumulated: S drifted linearly, 1.5e-18 a step on the rigid body under Gonzalez (0.007 ulp;
    1.5e-13 after 10^5 steps, 1.5e-11 after 10^7) and 4.2e-18 on the quartic body.  Anchored to S(x0) as H is
    to H(x0), it stays at round-off: below 16 ulps, and a fitted drift below 1e-21 a step (1e-14 over 10^7
    steps; the slow lane runs them)."""
    sol = geomint.solve(FREE_BODIES[body], X0, (0.0, 5000.0), 0.05, method=method, save_every=100)
    assert sol.success, sol.message
    worst, slope = _casimir_drift(sol, 100)
    assert worst <= 16 * EPS, f"max |S - S0| / S0 = {worst:.3g} ({worst / EPS:.0f} ulps), drift {slope:.3g} a step"
    assert abs(slope) <= 1e-21, f"S drifts by {slope:.3g} a step ({slope * 1e7:.3g} over 10^7 steps)"
    assert sol.energy_error <= 16 * EPS


@pytest.mark.slow
@pytest.mark.parametrize("method", DISCRETE_GRADIENTS, ids=lambda m: m.name)
def test_ten_million_steps_casimir_at_round_off(method):
    """10^7 steps of the free rigid body (eps = 0), h = 0.05: max |S - S0| / S0 <= 1e-14, as H (Gonzalez let S
    drift by 1.5e-11)."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.0)
    sol = geomint.solve(body, X0, (0.0, 5e5), 0.05, method=method, save_every=1000)
    assert sol.success and sol.n_steps == 10**7
    worst, slope = _casimir_drift(sol, 1000)
    assert worst <= 1e-14, (worst, slope)
    assert sol.energy_error <= 1e-14, sol.energy_error
