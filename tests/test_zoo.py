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
import zoo
from hypothesis import given, settings
from hypothesis import strategies as st

import geomint
import geomint.testing as gt
from geomint._kernels.layout import NEWTON_FAILED
from geomint.integrators.composition import gammas

EPS = np.finfo(float).eps
ANIMALS = zoo.everything()
METHODS = gt.structure_preserving_methods() + [
    geomint.Strang(),
    geomint.Yoshida4(),
    geomint.KahanLi6(),
    geomint.KahanLi8(),
    geomint.Suzuki4(),
    geomint.SuzukiUmeno8(),
    geomint.Yoshida6(),
    geomint.Yoshida4(geomint.AVF()),
    geomint.Strang(geomint.Gonzalez(), geomint.AVF()),
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


def stiffness(system, x):
    """The largest |eigenvalue| of the field's Jacobian at ``x`` (central differences)."""
    x = np.asarray(x, dtype=float)
    delta = 1e-6 * max(1.0, float(np.max(np.abs(x))))
    columns = [(np.asarray(system.xi(x + e)) - np.asarray(system.xi(x - e))) / (2 * delta) for e in np.eye(3) * delta]
    return float(np.max(np.abs(np.linalg.eigvals(np.column_stack(columns)))))


def in_the_backward_limit(animal, method, sol, h):
    """A run that stopped where docs/hard_cases.md says a composition's backward sub-step may have no
    discrete-gradient solution: Newton failed, and the longest backward sub-step ``|gamma_min| h`` times the
    stiffness at the last state kept is at or beyond the lower edge of the band, ``|gamma_min| h lambda >~ 1.18``
    (the band's upper edge depends on the system: 2.78 on the relaxing body, beyond 5.7 on the quartic one)."""
    if not isinstance(method, geomint.Composition) or sol.status != NEWTON_FAILED:
        return False
    backward = -min(gammas(method.scheme))
    return backward * abs(h) * stiffness(animal.system, sol.x_final) >= 1.0


@pytest.mark.parametrize("animal", ANIMALS, ids=lambda a: a.name)
@pytest.mark.parametrize("method", METHODS, ids=_ids)
def test_every_step_keeps_H_and_does_not_raise_S(animal, method):
    """8 steps from random states with random h (hypothesis), each checked.  A composition may stop in its
    documented limit (``in_the_backward_limit``), with every step before it checked."""

    @settings(max_examples=25)
    @given(x0=animal.states, h=st.floats(*animal.h))
    def check(x0, h):
        sol = geomint.solve(animal.system, x0, (0.0, 8 * h), h, method=method)
        assert sol.success or in_the_backward_limit(animal, method, sol, h), sol.message
        assert not per_step_violations(animal, sol, method), per_step_violations(animal, sol, method)

    check()


@pytest.mark.xfail(strict=True, reason="known limit (docs/hard_cases.md): a coordinate far below the others")
@pytest.mark.parametrize(
    ("name", "x0"),
    [
        ("lorenz_nevir", (0.0, 7.23284551e-138, 0.0)),
        ("lorenz_nevir", (0.0, 1e-60, 0.0)),
        ("lorenz_nevir", (0.0, 1.4302192e-262, 4.9406565e-324)),
    ],
)
def test_coordinates_far_below_the_others_are_a_known_limit(name, x0):
    """Found by hypothesis: with the quadratic terms of H below ~1e-110 of its linear ones, the dissipative z
    increment is lost and H moves by ~6 % of its terms.  Strict: this fails the suite once the limit is lifted."""
    animal = next(a for a in ANIMALS if a.name == name)
    method = geomint.Gonzalez()
    sol = geomint.solve(animal.system, x0, (0.0, 8 * 0.0078125), 0.0078125, method=method)
    assert sol.success and not per_step_violations(animal, sol, method)


@pytest.mark.xfail(strict=True, reason="known limit (docs/hard_cases.md): projected methods at small amplitude")
@pytest.mark.parametrize(
    ("method", "x0"),
    [
        (geomint.Projected(geomint.RK4()), (0.0, 1e-5, 1.07541879e-25)),
        (geomint.Projected(geomint.RK4()), (0.0, 1e-5, 1e-14)),
        (geomint.Projected(geomint.DormandPrince54()), (0.0, 1e-5, 1e-12)),
    ],
    ids=["rk4-1e-25", "rk4-1e-14", "dp54-1e-12"],
)
def test_projected_methods_at_small_amplitude_are_a_known_limit(method, x0):
    """Found by hypothesis on the dissipative oscillator (S = z^2/2): with |x| ~ 1e-5 the projection lets S rise
    by ~1e-7 of itself a step (its rise tolerance scales with |grad S|_inf |x|_inf, which mixes the components);
    at |x| >= 1e-3 no rise was found at any z/y down to 1e-30.  Strict: this fails the suite once it is fixed."""
    animal = next(a for a in ANIMALS if a.name == "dissipative_oscillator")
    sol = geomint.solve(animal.system, x0, (0.0, 1.0), 0.125, method=method)
    assert sol.success and not per_step_violations(animal, sol, method)


@pytest.mark.xfail(strict=True, reason="known limit (docs/hard_cases.md): projected methods at small amplitude")
def test_a_projected_pair_on_the_degenerate_tail_is_the_same_known_limit():
    """Found by hypothesis (the random profile) in tests/test_adaptive.py, on the code before and after the inlined
    step loop alike: adaptive Projected(DormandPrince54()) on degenerate example 2 from z ~ 1e-29, where S ~ 1e-60;
    at step 8 S rises from 1.3e-60 by 2.3e-59, ~3e15 ulps of S (the projection's rise tolerance scales with the
    other components, as above).  Strict: this fails the suite once it is fixed."""
    animal = next(a for a in ANIMALS if a.name == "degenerate_example_2")
    method = geomint.Projected(geomint.DormandPrince54())
    x0 = (1.0, 0.0, 1.15841246e-29)
    sol = geomint.solve(animal.system, x0, (0.0, 16 * animal.h[1]), rtol=1e-3, atol=1e-5, method=method)
    assert sol.success and not per_step_violations(animal, sol, method)


@pytest.mark.parametrize(
    ("name", "monotone", "x0"),
    [
        ("coupled_rigid_body", True, (1.0, 1.0, 1.125)),
        ("quartic_rigid_body", False, (0.0, 1.0, 1.1875)),
        ("quartic_rigid_body", False, (0.0, 1.125, 1.125)),
    ],
)
def test_yoshida4_stops_only_in_its_documented_limit(name, monotone, x0):
    """Cases hypothesis found at h = 0.09375: the backward sub-step (1.70 h) has no root near the flow, inside
    the documented band; at h = 0.05 (below it) the same starts run."""
    animal = next(a for a in ANIMALS if a.name == name)
    method = geomint.Yoshida4(geomint.Gonzalez(), monotone=monotone)
    stopped = geomint.solve(animal.system, x0, (0.0, 0.75), 0.09375, method=method)
    assert not stopped.success and in_the_backward_limit(animal, method, stopped, 0.09375), stopped.message
    assert not per_step_violations(animal, stopped, method)
    below = geomint.solve(animal.system, x0, (0.0, 0.4), 0.05, method=method)
    assert below.success and not in_the_backward_limit(animal, method, below, 0.05), below.message


@pytest.mark.parametrize("method", [geomint.Gonzalez(), geomint.ItohAbe(), geomint.AVF()], ids=_ids)
def test_a_long_forward_step_runs_where_rk4_does(method):
    """Found by hypothesis on the quartic body: at h = 0.09375 (h lambda = 1.8) from (1, 1.1875, 1.125) Newton's
    full steps diverge from every start the step tries, and RK4 runs.  The step's damped last attempt
    (docs/hard_cases.md, "Long forward steps") runs it: every step kept, the first exact to its ulps."""
    animal = next(a for a in ANIMALS if a.name == "quartic_rigid_body")
    x0, h = (1.0, 1.1875, 1.125), 0.09375
    assert geomint.solve(animal.system, x0, (0.0, animal.T), h, method="rk4", save_every=None).success
    sol = geomint.solve(animal.system, x0, (0.0, 16 * h), h, method=method)
    assert sol.success, sol.message
    assert np.linalg.norm(sol.x[1] - sol.x[0]) > 0.5 * np.linalg.norm(x0)  # the first step: half the state's size
    assert not per_step_violations(animal, sol, method), per_step_violations(animal, sol, method)


#: the methods whose runs must never fail on the zoo (issue 9): the discrete gradients of
#: Gonzalez type and the splittings and compositions of them
ROBUST = [
    geomint.Gonzalez(),
    geomint.AVF(),
    geomint.DampedGonzalez(),
    geomint.Strang(),
    geomint.Yoshida4(),
    geomint.KahanLi8(),
    geomint.Projected(geomint.Gonzalez()),
]


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
    animal = zoo.Animal(
        body,
        zoo._box((-1, -1, -1), (1, 1, 1)),
        (0.1, 0.1),
        zoo._quadratic_terms((0.5, 1.0, 1.5)),
        lambda x: 0.5 * float(x @ x),
        10.0,
    )
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
    clean = geomint.solve(
        zoo.drifter(radius=1e300), [0.0, y0, 0.0], (0.0, 8.0), h, method=method, save_every=save_every
    )
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
    np.testing.assert_array_equal(
        sol.x[-1], clean.x[:][np.searchsorted(clean.t, sol.t[-1] - 1e-9)] if save_every == 1 else sol.x[-1]
    )


@pytest.mark.parametrize("save_every", [1, 7, 10, None])
@pytest.mark.parametrize("method", [geomint.RK4(), geomint.DormandPrince54()], ids=_ids)
def test_S_turning_nan_under_an_explicit_method_is_never_saved(method, save_every):
    """S is NaN beyond |y| = 5 while grad S stays finite, so an explicit step goes on; a run saving every k-th
    state evaluates H and S at those states only.  It used to stop at the next saved state and save the state
    before it as the last good one, though S was NaN there too (RK4, save_every = 10: step 50 failed, its last row,
    t = 4.9, had S = NaN; save_every = 7: step 49, t = 4.8; None: step 80, t = 7.9).  Now no saved row has a
    non-finite H or S: where the state before the failing one is beyond the domain too, the run is cut back to
    the last saved state and the failure reported at the step after it, naming S; every row kept is the clean
    run's state."""
    h, y0 = 0.1, 0.55
    clean = geomint.solve(
        zoo.drifter_with_bounded_S(radius=1e300), [0.0, y0, 0.0], (0.0, 8.0), h, method=method, save_every=1
    )
    sol = geomint.solve(
        zoo.drifter_with_bounded_S(radius=5.0), [0.0, y0, 0.0], (0.0, 8.0), h, method=method, save_every=save_every
    )
    crossing = int(np.ceil((5.0 - y0) / h))  # the first state beyond the radius
    every = save_every or clean.n_steps
    assert sol.status == -2 and not sol.success, sol.message
    assert np.all(np.isfinite(sol.H)) and np.all(np.isfinite(sol.S)), (sol.t[-1], sol.S[-1])
    assert "`S`" in sol.message, sol.message
    assert f"{len(sol.t)} saved state" in sol.message, sol.message
    assert crossing - every < sol.failed_step <= crossing, (sol.failed_step, crossing)
    assert sol.n_steps == sol.failed_step - 1
    assert sol.t[-1] == pytest.approx((sol.failed_step - 1) * h)
    steps = np.rint(sol.t / h).astype(int)
    np.testing.assert_array_equal(sol.x, clean.x[steps])
    np.testing.assert_array_equal(sol.S, clean.S[steps])


@pytest.mark.parametrize(
    "method",
    [m for m in gt.structure_preserving_methods() if isinstance(m, geomint.integrators.DiscreteGradient)],
    ids=_ids,
)
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
