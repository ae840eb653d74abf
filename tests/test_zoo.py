"""The core promise on systems the library has never seen (issue 9).

Every structure-preserving method of the whole field runs over every system of
the zoo (``tests/zoo.py``: systems users bring, built through the public
constructor) and of the catalogue, from random states and step sizes:

* per full step, ``|H(x_{n+1}) - H(x_n)| <= 16 ulp`` of the terms of H and S
  rises by at most 4 ulp of its terms (for the methods that declare it);
* runs from many random starts do not fail (the Newton iteration converges at
  and near attractors);
* split and composed steps do not drift over a million steps;
* a user function that turns NaN is reported, with the states before it kept.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import geomint
import geomint.testing as gt

import zoo

EPS = np.finfo(float).eps
ANIMALS = zoo.everything()
METHODS = gt.structure_preserving_methods() + [
    geomint.Strang(), geomint.Yoshida4(), geomint.KahanLi6(), geomint.KahanLi8(), geomint.Suzuki4(),
    geomint.SuzukiUmeno8(), geomint.Yoshida6(), geomint.Yoshida4(geomint.AVF()), geomint.Strang(geomint.Gonzalez(), geomint.AVF()),
]
METHODS = list({repr(m): m for m in METHODS}.values())


def _ids(method):
    return repr(method).replace("geomint.", "")


def per_step_violations(animal, sol, method):
    """Saved consecutive pairs that break what ``method`` declares, in ulps of the terms: of F at either
    end (``F(x') - F(x)`` rounds at the larger; from x0 = (3, 0, 0) on the Lorenz-Nevir system the
    terms of H are 0 at x0 and ~1e-10 one step later) and of the step's identity ``grad F . dx`` (the
    increment rounds at the size of the terms of h F and carries that into F; as
    tests/test_discrete_gradients.py measures a discrete gradient)."""
    bad = []
    for k in range(len(sol.t) - 1):
        x, x_next = sol.x[k], sol.x[k + 1]
        step = np.abs(x_next - x)
        if method.energy_exact:
            terms = max(animal.terms_H(x), animal.terms_H(x_next), np.finfo(float).tiny)
            terms += np.abs(animal.system.grad_H(x)) @ step
            dH = abs(sol.H[k + 1] - sol.H[k]) / (EPS * terms)
            if dH > 16:
                bad.append(f"step {k + 1}: |dH| = {dH:.1f} ulp")
        if method.dissipative:
            terms = max(animal.terms_S(x), animal.terms_S(x_next), np.finfo(float).tiny)
            terms += np.abs(animal.system.grad_S(x)) @ step
            dS = (sol.S[k + 1] - sol.S[k]) / (EPS * terms)
            if dS > 4:
                bad.append(f"step {k + 1}: S rose by {dS:.1f} ulp")
    return bad


@pytest.mark.parametrize("animal", ANIMALS, ids=lambda a: a.name)
@pytest.mark.parametrize("method", METHODS, ids=_ids)
def test_every_step_keeps_H_and_does_not_raise_S(animal, method):
    """8 steps from random states with random h (hypothesis), each checked."""

    @settings(max_examples=25)
    @given(x0=animal.states, h=st.floats(*animal.h))
    def check(x0, h):
        sol = geomint.solve(animal.system, x0, (0.0, 8 * h), h, method=method)
        assert sol.success, sol.message
        assert not per_step_violations(animal, sol, method), per_step_violations(animal, sol, method)

    check()


#: the methods whose runs must never fail on the zoo (issue 9): the discrete gradients of
#: Gonzalez type and the splittings and compositions of them
ROBUST = [geomint.Gonzalez(), geomint.AVF(), geomint.DampedGonzalez(), geomint.Strang(), geomint.Yoshida4(),
          geomint.KahanLi8(), geomint.Projected(geomint.Gonzalez())]


@pytest.fixture(scope="module")
def rk4_runs():
    """Whether RK4 runs from a start, by ``(system, T, h, x0)``: the methods of ``ROBUST`` share their starts and
    steps, so each reference run is computed once rather than once per method."""
    verdicts = {}

    def runs(animal, x0, h):
        key = (animal.name, animal.T, h, np.asarray(x0, dtype=float).tobytes())
        if key not in verdicts:
            verdicts[key] = geomint.solve(animal.system, x0, (0.0, animal.T), h, method="rk4", save_every=None).success
        return verdicts[key]

    return runs


@pytest.mark.parametrize("animal", ANIMALS, ids=lambda a: a.name)
@pytest.mark.parametrize("method", ROBUST, ids=_ids)
def test_no_run_fails_from_random_starts(animal, method, request, rk4_runs):
    """Random starts run to the long-time regime (Lorenz-Nevir: into its attractor) without a failure,
    at the largest step where RK4 also runs.

    Yoshida4 runs at half that step: its middle sub-step goes backward over 1.70 h, where the
    dissipative part is anti-dissipative, and at the largest step its implicit equation has no root
    near the flow from a few starts (of 200: 6 on the coupled body, 5 on the quartic body, 6 on
    degenerate example 2; none at h/2)."""
    n = 200 if request.config.getoption("--zoo-starts") is None else int(request.config.getoption("--zoo-starts"))
    starts = animal.box.draw(np.random.default_rng(9), n // (4 if method.order > 2 else 1))
    h = animal.h[1] / (2 if isinstance(method, geomint.Yoshida4) else 1)
    failures = []
    for x0 in starts:
        if not rk4_runs(animal, x0, h):
            continue  # only where the generic method runs too
        sol = geomint.solve(animal.system, x0, (0.0, animal.T), h, method=method, save_every=None)
        if not sol.success:
            failures.append(sol.message)
    assert not failures, f"{len(failures)} of {len(starts)} runs failed; first: {failures[0]}"


@pytest.mark.slow
@pytest.mark.parametrize("method", [geomint.Strang(), geomint.Yoshida4(), geomint.KahanLi8()], ids=_ids)
def test_split_and_composed_steps_do_not_drift(method):
    """10^6 steps on the non-polynomial system: max |H - H0| within a random walk's 5 sigma sqrt(n) of
    the per-step spread sigma, and a mean per-step change within 0.01 ulp of zero."""
    animal = next(a for a in ANIMALS if a.name == "cosh_exp")
    x0 = np.array([0.9, -0.4, 0.7])
    n = 10**6
    sol = geomint.solve(animal.system, x0, (0.0, n * 0.01), 0.01, method=method)
    assert sol.success, sol.message
    ulp = EPS * animal.terms_H(x0)
    steps = np.diff(sol.H) / ulp
    sigma = steps.std()
    drift = np.abs(sol.H - sol.H[0]).max() / ulp
    mean = (sol.H[-1] - sol.H[0]) / n / ulp
    print(f"{method!r}: sigma {sigma:.3f} ulp/step, max |H - H0| {drift:.1f} ulp, mean {mean:.2e} ulp/step")
    assert drift <= 5 * sigma * np.sqrt(n)
    assert abs(mean) <= 0.01


@pytest.mark.parametrize("method", [geomint.ItohAbe(), geomint.SymmetrizedItohAbe()], ids=_ids)
def test_itoh_abe_keeps_H_per_step_under_stiffness(method):
    """The stiff relaxing body (eps = 1e3, h = 0.1): every step within 16 ulp of the terms of H."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=1e3)
    animal = zoo.Animal(body, zoo._box((-1, -1, -1), (1, 1, 1)), (0.1, 0.1), zoo._quadratic_terms((0.5, 1.0, 1.5)),
                        lambda x: 0.5 * float(x @ x), 10.0)
    sol = geomint.solve(body, [np.cos(1.1), 0.0, np.sin(1.1)], (0.0, 10.0), 0.1, method=method)
    assert sol.success, sol.message
    assert not per_step_violations(animal, sol, method)


ALL_WHOLE_FIELD = [cls() for cls in geomint.integrators.INTEGRATORS.values() if cls().whole_field]


@pytest.mark.parametrize("save_every", [1, 7, None])
@pytest.mark.parametrize("method", ALL_WHOLE_FIELD, ids=_ids)
def test_a_function_turning_nan_is_reported_with_the_states_before_it(method, save_every):
    """H is NaN beyond |y| = 5 and the state crosses it at t = 5 - y0: the run stops with NON_FINITE at
    that step (a sub-step reaching further than its step may stop it up to 2 steps earlier), names the
    function, keeps every state before it bit for bit and counts the rows it keeps."""
    h, y0 = 0.1, 0.05
    clean = geomint.solve(zoo.drifter(radius=1e300), [0.0, y0, 0.0], (0.0, 8.0), h, method=method, save_every=save_every)
    sol = geomint.solve(zoo.drifter(radius=5.0), [0.0, y0, 0.0], (0.0, 8.0), h, method=method, save_every=save_every)
    crossing = int(np.ceil((5.0 - y0) / h))  # the first state beyond the radius
    assert sol.status == -2 and not sol.success, sol.message
    assert crossing - 2 <= sol.failed_step <= crossing, (sol.failed_step, crossing)
    assert "`H`" in sol.message or "`grad_H`" in sol.message, sol.message
    assert f"{len(sol.t)} saved state" in sol.message, sol.message
    assert np.all(np.isfinite(sol.x)) and np.all(np.isfinite(sol.H))
    kept = len(sol.t) - 1  # the last row is the last good state, saved at the failure
    np.testing.assert_array_equal(sol.x[:kept], clean.x[:kept])
    assert sol.t[-1] == pytest.approx((sol.failed_step - 1) * h)
    np.testing.assert_array_equal(sol.x[-1], clean.x[:][np.searchsorted(clean.t, sol.t[-1] - 1e-9)] if save_every == 1
                                  else sol.x[-1])


@pytest.mark.parametrize("method", [m for m in gt.structure_preserving_methods()
                                    if isinstance(m, geomint.integrators.DiscreteGradient)], ids=_ids)
def test_steps_settling_onto_an_attractor_take_few_newton_iterations(method):
    """2 10^4 steps of the relaxing body into its stable pole (|dx| << |x|, then |dx| ~ 0): fewer than
    2 Newton iterations per step on average.  (Itoh-Abe once converged there to roots keeping H to
    ~5 ulp only and spent ~90 iterations a step before accepting one.)"""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
    sol = geomint.solve(body, [np.cos(1.1), 0.0, np.sin(1.1)], (0.0, 1000.0), 0.05, method=method, save_every=None)
    assert sol.success, sol.message
    assert sol.n_newton / sol.n_steps < 2.0, sol.n_newton / sol.n_steps


def test_constant_and_linear_terms_are_measured_from_the_origin():
    """``Model.origin`` holds H, grad H, S, grad S at 0 (what the kernels' term scale reads); 0 where a
    function is singular there, so the scale stays finite."""
    offset = next(a for a in ANIMALS if a.name == "offset_oscillator").system
    assert offset.model.origin.tolist() == [450.0, -30.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    singular = geomint.MetriplecticSystem.from_expressions(H="log(x**2 + y**2 + z**2)/2", S="z**2/2", J=("0", "0", "1"))
    assert np.all(np.isfinite(singular.model.origin)) and singular.model.origin[0] == 0.0
    x = np.array([30.5, 0.4, 0.8])
    assert gt.origin_terms(offset, "H", x) == 450.0 + 30.0 * 30.5
