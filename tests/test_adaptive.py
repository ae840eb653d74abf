"""Adaptive steps and the scipy keywords (issue 11): t_eval, events, dense_output, args, backward spans.

* every accepted adaptive step keeps H to 16 ulp of its terms and S does not rise by more than 4 ulp,
  over the zoo of user systems (hypothesis), for each kind of error estimate;
* the achieved error follows the tolerance (within 10x of rtol, rtol from 1e-4 to 1e-10) for the projected
  pairs and the monotone Yoshida4 composition of Gonzalez steps (step doubling, tolerance-proportional);
  Gonzalez alone, controlled per step at order 2, lags it as rtol^(2/3) (tested as such);
* t_eval and event times against scipy's semantics and closed forms;
* every new keyword validated at the boundary.
"""

import dataclasses
import math
import types

import numpy as np
import pytest
import zoo
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from test_zoo import per_step_violations

import geomint
from geomint.integrators import tableaux

EPS = np.finfo(float).eps
BODY = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
M0 = np.array([math.cos(1.1), 0.0, math.sin(1.1)])
#: one method per error estimate: against RK4 (discrete gradients), the embedded pair under the
#: projection, step doubling (DampedGonzalez at order 2; the monotone Yoshida4 composition of Gonzalez
#: steps at order 4, whose tolerance is made proportional)
ADAPTIVE = [
    geomint.Gonzalez(),
    geomint.Projected(geomint.DormandPrince54()),
    geomint.DampedGonzalez(),
    geomint.Yoshida4(geomint.Gonzalez(), monotone=True),
]


def _ids(method):
    return repr(method).replace("geomint.", "")


def _reference(system, x0, t_end):
    """scipy's DOP853 at rtol 1e-13 with dense output: the reference trajectory."""
    return solve_ivp(
        lambda t, y: system.xi(y), (0.0, t_end), x0, method="DOP853", rtol=1e-13, atol=1e-15, dense_output=True
    )


@pytest.mark.parametrize("animal", zoo.everything(), ids=lambda a: a.name)
@pytest.mark.parametrize("method", ADAPTIVE, ids=_ids)
def test_every_accepted_adaptive_step_keeps_H_and_does_not_raise_S(animal, method):
    """Random starts and tolerances: every saved (accepted) step checked in ulps of the terms.  rtol 1e-12 is
    where the anchor's reach shortens and steps are pulled back onto H(x0) (``geomint._kernels.control`` docstring)."""

    @settings(max_examples=8, deadline=None)
    @given(x0=animal.states, rtol=st.sampled_from([1e-3, 1e-6, 1e-9, 1e-12]))
    def check(x0, rtol):
        sol = geomint.solve(animal.system, x0, (0.0, 16 * animal.h[1]), rtol=rtol, atol=rtol * 1e-2, method=method)
        assert sol.success, sol.message
        assert len(sol.t) == sol.n_steps + 1
        assert not per_step_violations(animal, sol, method), per_step_violations(animal, sol, method)

    check()


@pytest.mark.parametrize(
    "method",
    [
        geomint.Projected(geomint.DormandPrince54()),
        geomint.Projected(geomint.DormandPrince853()),
        geomint.Yoshida4(geomint.Gonzalez(), monotone=True),
    ],
    ids=_ids,
)
def test_the_achieved_error_follows_the_tolerance(method):
    """Max error along the trajectory (at every step, against a tight reference) within 10x of rtol over
    about one rotation (T = 10), and falling as rtol falls; H exact and S monotone throughout."""
    ref = _reference(BODY, M0, 10.0)
    errors = []
    for rtol in (1e-4, 1e-6, 1e-8, 1e-10):
        sol = geomint.solve(BODY, M0, (0.0, 10.0), rtol=rtol, atol=rtol, method=method)
        assert sol.success, sol.message
        assert sol.energy_error <= 16 * EPS and sol.S_rises == 0
        errors.append(np.max(np.abs(ref.sol(sol.t).T - sol.x)))
        assert errors[-1] <= 10 * rtol, (rtol, errors[-1])
    assert errors == sorted(errors, reverse=True), errors


def test_the_discrete_gradient_error_falls_like_the_tolerance_to_the_two_thirds():
    """Gonzalez controlled per step: its local error ~ rtol over ~ rtol^(-1/3) steps adds up to a global
    error ~ rtol^(2/3) (measured 25x rtol at 1e-4, 2700x at 1e-10 over T = 10): the slope of log error
    against log rtol is 2/3, not 1.  (This is the per-step control every adaptive code uses; the
    tolerance is a local one.)"""
    ref = _reference(BODY, M0, 10.0)
    rtols = np.array([1e-4, 1e-6, 1e-8, 1e-10])
    errors = []
    for rtol in rtols:
        sol = geomint.solve(BODY, M0, (0.0, 10.0), rtol=rtol, atol=rtol, method="gonzalez")
        assert sol.success and sol.energy_error <= 16 * EPS and sol.S_rises == 0
        errors.append(np.max(np.abs(ref.sol(sol.t).T - sol.x)))
    slope = np.polyfit(np.log(rtols), np.log(errors), 1)[0]
    assert 0.6 <= slope <= 0.75, (slope, errors)


def test_adaptive_steps_are_fewer_than_fixed_ones_at_the_same_accuracy():
    """Gonzalez over the relaxing body's transient and tail (T = 200): the adaptive run attempts fewer than
    1/4 of the steps of the fixed run of the same accuracy along the trajectory (6.4x fewer measured),
    because its steps grow as the state settles (steps are counted, not timed)."""
    ref = _reference(BODY, M0, 200.0)
    adaptive = geomint.solve(BODY, M0, (0.0, 200.0), rtol=1e-8, atol=1e-8, method="gonzalez")
    err = np.max(np.abs(ref.sol(adaptive.t).T - adaptive.x))
    fixed_h = 0.5
    while True:  # the largest fixed step (halving) as accurate as the adaptive run
        fixed = geomint.solve(BODY, M0, (0.0, 200.0), fixed_h, method="gonzalez")
        if np.max(np.abs(ref.sol(fixed.t).T - fixed.x)) <= err:
            break
        fixed_h /= 2
    assert adaptive.n_steps + adaptive.n_rejected < fixed.n_steps / 4, (adaptive.n_steps, fixed.n_steps)
    assert np.diff(adaptive.t)[-1] > 100 * np.diff(adaptive.t)[:10].min()


def test_rejected_steps_are_counted_and_only_accepted_ones_kept():
    sol = geomint.solve(BODY, M0, (0.0, 5.0), rtol=1e-10, atol=1e-10, first_step=1.0, method="gonzalez")
    assert sol.success and sol.n_rejected >= 1
    assert len(sol.t) == sol.n_steps + 1 and np.all(np.diff(sol.t) > 0)
    assert "rejected" in sol.message


def test_stiff_relaxation_runs_adaptively_with_damped_gonzalez():
    """eps = 1e3: DampedGonzalez's estimate (step doubling) needs no explicit reference, so its steps are not
    held to the explicit stability limit h < 2.8 / (eps |grad H|^2) ~ 3e-3."""
    stiff = BODY.with_effects(eps=1e3)
    sol = geomint.solve(stiff, M0, (0.0, 10.0), rtol=1e-6, atol=1e-8, method="damped_gonzalez")
    assert sol.success, sol.message
    assert sol.energy_error <= 16 * EPS and sol.S_rises == 0
    assert np.max(np.diff(sol.t)) > 0.1
    np.testing.assert_allclose(sol.x[-1], [0.0, 0.0, np.sqrt(2 * BODY.H(M0) / 1.5)], atol=1e-6)


@pytest.mark.parametrize("method", [geomint.Gonzalez(), geomint.ItohAbe(), geomint.AVF()], ids=_ids)
def test_near_an_equilibrium_a_tight_tolerance_does_not_make_the_run_crawl(method):
    """The quartic body relaxing onto its major axis at rtol = atol = 1e-12: the anchor's correction of a few
    ulps of H moves the state along the level set by ~ulp |J| / |xi|, which near the axis exceeds the tolerance
    at every step length.  Before the anchor's reach was controlled (``geomint._kernels.control`` docstring), Gonzalez
    crawled near t = 19.82 (18 million rejections in 0.005 time units) and did not finish in minutes."""
    quartic = geomint.systems.quartic_rigid_body(k=0.5, eps=0.1)
    sol = geomint.solve(quartic, M0, (0.0, 20.0), rtol=1e-12, atol=1e-12, method=method)
    assert sol.success, sol.message
    assert sol.n_rejected <= 0.05 * sol.n_steps
    assert sol.energy_error <= 16 * EPS and sol.S_rises == 0
    # every accepted step near the axis (where steps are pulled back onto H(x0)) in ulps of the terms
    animal = dataclasses.replace(next(a for a in zoo.catalogue() if a.system.name == quartic.name), system=quartic)
    near = sol.t >= 19.0
    tail = types.SimpleNamespace(t=sol.t[near], x=sol.x[near], H=sol.H[near], S=sol.S[near])
    assert len(tail.t) > 100 and not per_step_violations(animal, tail, method)
    reference = _reference(quartic, M0, 20.0).y[:, -1]
    np.testing.assert_allclose(sol.x[-1], reference, atol=(1e-12) ** (2 / 3))  # the lag tested above


def test_steps_with_a_shortened_anchor_reach_are_pulled_back_onto_the_initial_energy():
    """Relaxing body to T = 1000 at rtol = atol = 1e-13: the reach shortens on the way to the axis, and each
    such step is pulled back along grad H onto H(x0).  Without the pull back the energy of the saved states
    wandered to 142 eps (measured); with it, 3 eps."""
    sol = geomint.solve(BODY, M0, (0.0, 1000.0), rtol=1e-13, atol=1e-13, method="gonzalez")
    assert sol.success, sol.message
    assert sol.energy_error <= 16 * EPS and sol.S_rises == 0


@pytest.mark.parametrize("method", [geomint.Yoshida4(), geomint.RK4(), geomint.DormandPrince853()], ids=_ids)
def test_every_method_runs_adaptively(method):
    """Compositions and RK4 by step doubling, a bare pair by its own estimate: the error follows rtol
    (within 20x over T = 5; Yoshida4's doubling estimate gives 12x)."""
    ref = _reference(BODY, M0, 5.0)
    sol = geomint.solve(BODY, M0, (0.0, 5.0), rtol=1e-8, atol=1e-8, method=method)
    assert sol.success, sol.message
    assert np.max(np.abs(ref.sol(sol.t).T - sol.x)) <= 2e-7
    if method.energy_exact:
        assert sol.energy_error <= 16 * EPS


# -- t_eval, dense output, y ----------------------------------------------------------------------
@pytest.mark.parametrize("h", [None, 0.01], ids=["adaptive", "fixed"])
def test_t_eval_returns_states_of_the_method_at_exactly_those_times(h):
    t_eval = np.array([0.0, 0.3, 1.0, np.pi, 7.25, 10.0])
    kwargs = {"rtol": 1e-10, "atol": 1e-12, "method": geomint.Projected(geomint.DormandPrince54())} if h is None else {}
    sol = geomint.solve(BODY, M0, (0.0, 10.0), h, t_eval=t_eval, **kwargs)
    ref = solve_ivp(lambda t, y: BODY.xi(y), (0.0, 10.0), M0, method="DOP853", rtol=1e-13, atol=1e-15, t_eval=t_eval)
    np.testing.assert_array_equal(sol.t, ref.t)
    assert sol.y.shape == ref.y.shape == (3, len(t_eval))
    np.testing.assert_allclose(sol.y, ref.y, atol=1e-8 if h is None else 1e-5)
    assert sol.energy_error <= 16 * EPS and sol.S_rises == 0  # states of the method, not interpolated


def test_t_eval_without_t0_or_t_end_returns_only_t_eval():
    sol = geomint.solve(BODY, M0, (0.0, 3.0), t_eval=[0.5, 2.0])
    np.testing.assert_array_equal(sol.t, [0.5, 2.0])


def test_dense_output_interpolates_between_steps():
    sol = geomint.solve(BODY, M0, (0.0, 10.0), rtol=1e-10, atol=1e-12, method="gonzalez", dense_output=True)
    ref = _reference(BODY, M0, 10.0)
    times = np.linspace(0.0, 10.0, 777)
    assert sol.sol(times).shape == (3, 777) and sol.sol(2.5).shape == (3,)
    np.testing.assert_allclose(sol.sol(times), ref.sol(times), atol=1e-7)
    np.testing.assert_array_equal(sol.sol(sol.t[5]), sol.x[5])
    with pytest.raises(ValueError, match="solved interval"):
        sol.sol(10.5)


# -- events --------------------------------------------------------------------------------------
def test_event_time_of_the_dissipative_oscillator_against_its_closed_form():
    """S = z, eps = 1, x0 = (0.6, 0, 0.8): z(t) = -tanh(t - artanh 0.8) (docs/references.md R5), zero at
    t* = artanh 0.8; z = 0.5 at t = artanh 0.8 - artanh 0.5 (falling)."""
    osc = geomint.systems.dissipative_oscillator((0.0, 1.0), eps=1.0)
    x0 = [0.6, 0.0, 0.8]
    half = geomint.events.crossing(lambda x: x[2], 0.5, direction=-1.0)
    zero = geomint.events.crossing(lambda x: x[2], 0.0, terminal=True)
    sol = geomint.solve(
        osc,
        x0,
        (0.0, 5.0),
        rtol=1e-12,
        atol=1e-14,
        events=[half, zero],
        method=geomint.Projected(geomint.DormandPrince853()),
    )
    assert sol.status == 1 and sol.success
    assert abs(sol.t_events[0][0] - (math.atanh(0.8) - math.atanh(0.5))) <= 1e-10
    assert abs(sol.t_events[1][0] - math.atanh(0.8)) <= 1e-10
    assert sol.t[-1] == sol.t_events[1][0]
    np.testing.assert_array_equal(sol.x[-1], sol.x_events[1][0])
    assert abs(sol.x_events[1][0][2]) <= 1e-10
    # the event state is a step of the method: on H = H0 to round-off
    assert abs(osc.H(sol.x_events[1][0]) - osc.H(x0)) <= 4 * EPS


def test_events_follow_scipy_semantics():
    """A non-terminal event with each direction, counted against scipy's solve_ivp on the same problem."""

    def up(t, x):
        return x[0]

    up.direction = 1.0

    def down(t, x):
        return x[0]

    down.direction = -1.0

    def both(t, x):
        return x[1]

    sol = geomint.solve(BODY, M0, (0.0, 30.0), rtol=1e-10, atol=1e-12, events=[up, down, both])
    ref = solve_ivp(
        lambda t, y: BODY.xi(y), (0.0, 30.0), M0, method="DOP853", rtol=1e-12, atol=1e-14, events=[up, down, both]
    )
    for ours, theirs in zip(sol.t_events, ref.t_events):
        assert len(ours) == len(theirs) > 0
        np.testing.assert_allclose(ours, theirs, atol=1e-8)
    assert sol.y_events is sol.x_events


def test_a_terminal_event_with_a_count_stops_at_that_occurrence():
    def crossing(t, x):
        return x[1]

    crossing.terminal = 3
    sol = geomint.solve(BODY, M0, (0.0, 100.0), events=crossing)
    assert sol.status == 1 and len(sol.t_events[0]) == 3 and sol.t[-1] == sol.t_events[0][-1]


def test_an_event_that_never_occurs_gives_empty_arrays_as_scipy():
    """No zero of the event over the span: its times are an empty array and its states an empty (0, n) array,
    in R^3 and in R^n, beside an event that occurs; the run succeeds as without events."""
    sol = geomint.solve(BODY, M0, (0.0, 30.0), rtol=1e-8, events=[lambda t, x: x[2] - 5.0, lambda t, x: x[1]])
    assert sol.status == 0 and sol.t_events[0].shape == (0,) and sol.x_events[0].shape == (0, 3)
    assert len(sol.t_events[1]) > 0 and sol.x_events[1].shape == (len(sol.t_events[1]), 3)
    gas = geomint.systems.gas_containers()
    sol = geomint.solve(gas, [1.5, 0.0, 2.0, 2.0], (0.0, 1.0), rtol=1e-8, events=lambda t, x: x[2] - 5.0)
    assert sol.success and sol.t_events[0].shape == (0,) and sol.x_events[0].shape == (0, 4)


@pytest.mark.parametrize("h", [None, 0.125], ids=["adaptive", "fixed"])
def test_a_zero_exactly_at_a_step_end_is_one_event(h):
    """Steps land on t_eval times and on the grid, so g exactly 0 at a step's end is common: it is the end of one
    step and the start of the next, found once; a zero touched without a sign change, once; a terminal count
    of 2 is not reached by one zero."""
    t_eval = [0.25, 0.5, 0.75] if h is None else None
    sol = geomint.solve(
        BODY, M0, (0.0, 1.0), h, t_eval=t_eval, events=[lambda t, x: t - 0.5, lambda t, x: (t - 0.5) ** 2]
    )
    assert [ts.tolist() for ts in sol.t_events] == [[0.5], [0.5]] and sol.x_events[0].shape == (1, 3)

    def twice(t, x):
        return t - 0.5

    twice.terminal = 2
    sol = geomint.solve(BODY, M0, (0.0, 1.0), h, t_eval=t_eval, events=twice)
    assert sol.status == 0 and sol.t_events[0].tolist() == [0.5]


@pytest.mark.parametrize("h", [None, 0.1], ids=["adaptive", "fixed"])
def test_a_terminal_event_with_t_eval_keeps_its_state_and_counts_the_steps_to_it(h):
    """A terminal event before the first time of t_eval (the run used to end in an IndexError): the event's
    state is kept as the last row, as a failed run keeps its last state, the message names its time, and
    n_steps counts the steps to it (the chunk ran on past it); the same in R^n."""

    def stop(t, x):
        return t - 0.5

    stop.terminal = True
    for system, x0 in ((BODY, M0), (geomint.systems.gas_containers(), [1.5, 0.0, 2.0, 2.0])):
        sol = geomint.solve(system, x0, (0.0, 5.0), h, t_eval=[1.0, 2.0, 3.0], events=stop)
        assert sol.status == 1 and sol.t.tolist() == [0.5] and sol.t_events[0].tolist() == [0.5]
        np.testing.assert_array_equal(sol.x_final, sol.x_events[0][0])
        assert "A termination event occurred at t = 0.5, after" in sol.message
        full = geomint.solve(system, x0, (0.0, 5.0), h, events=stop)
        assert full.t[-1] == 0.5 and sol.n_steps == full.n_steps == len(full.t) - 1
        if h is not None:
            assert sol.n_steps == 5


def test_relaxed_stops_when_the_state_has_settled():
    sol = geomint.solve(BODY, M0, (0.0, 1e4), rtol=1e-9, atol=1e-12, events=geomint.events.relaxed(BODY, 1e-8))
    assert sol.status == 1 and sol.t[-1] < 1e4
    assert np.linalg.norm(BODY.xi(sol.x[-1])) == pytest.approx(1e-8, rel=1e-3)
    assert sol.energy_error <= 16 * EPS and sol.S_rises == 0


# -- args, backward --------------------------------------------------------------------------------
def test_args_override_the_params_of_the_system():
    osc = geomint.systems.dissipative_oscillator((0.0, 0.0, 1.0), eps=0.3)
    mine = geomint.solve(osc, [0.6, 0.0, 0.8], (0.0, 2.0), 0.01, args=(0.0, 1.0, 0.0))
    other = geomint.solve(
        geomint.systems.dissipative_oscillator((0.0, 1.0, 0.0), eps=0.3), [0.6, 0.0, 0.8], (0.0, 2.0), 0.01
    )
    np.testing.assert_array_equal(mine.x, other.x)


@pytest.mark.parametrize("h", [None, 0.01], ids=["adaptive", "fixed"])
def test_backward_integration_returns_to_the_start(h):
    kwargs = {"rtol": 1e-11, "atol": 1e-13} if h is None else {}
    forward = geomint.solve(BODY, M0, (0.0, 3.0), h, method="gonzalez", **kwargs)
    back = geomint.solve(BODY, forward.x[-1], (3.0, 0.0), h, method="gonzalez", **kwargs)
    assert back.success and back.t[-1] == 0.0 and np.all(np.diff(back.t) < 0)
    np.testing.assert_allclose(back.x[-1], M0, atol=1e-8 if h is None else 1e-5)
    assert np.all(np.diff(back.S) >= -4 * EPS)  # S rises as t falls
    assert back.S_rises == 0 and back.energy_error <= 16 * EPS


def test_backward_is_refused_where_a_projection_keeps_S_from_rising():
    with pytest.raises(ValueError, match="backward"):
        geomint.solve(BODY, M0, (1.0, 0.0), 0.1, method=geomint.Projected())


# -- the tableaux ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "tableau, name",
    [
        (tableaux.BOGACKI_SHAMPINE_32, "RK23"),
        (tableaux.DORMAND_PRINCE_54, "RK45"),
        (tableaux.DORMAND_PRINCE_853, "DOP853"),
    ],
)
def test_the_tableaux_are_scipys(tableau, name):
    from scipy.integrate._ivp import rk

    reference = getattr(rk, name)
    a, b, c, e, e_low, order, error_order = tableau
    s = len(b)
    A = np.zeros((s, s))
    for i, row in enumerate(a):
        A[i, : len(row)] = row
    np.testing.assert_array_equal(A[:, : reference.A.shape[1]], reference.A[:s])
    np.testing.assert_array_equal(b, reference.B)
    np.testing.assert_array_equal(c, reference.C)
    np.testing.assert_array_equal(e, reference.E5 if name == "DOP853" else reference.E)
    if name == "DOP853":
        np.testing.assert_array_equal(e_low, reference.E3)
    assert (order, error_order) == (reference.order, reference.error_estimator_order)
    # consistency: the weights sum to 1, the rows of A to the nodes, the error weights to 0
    assert math.isclose(sum(b), 1.0, abs_tol=8 * EPS) and abs(sum(e)) <= 64 * EPS
    np.testing.assert_allclose(A.sum(axis=1), c, atol=8 * EPS)


# -- bad input ----------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"h": 0.1, "rtol": 1e-6}, ValueError, "`rtol` cannot be given"),
        ({"rtol": 0.0}, ValueError, "`rtol` must be"),
        ({"rtol": float("nan")}, ValueError, "`rtol` must be"),
        ({"rtol": "1e-6"}, TypeError, "`rtol` must be a real number"),
        ({"atol": -1.0}, ValueError, "`atol` must be"),
        ({"max_step": 0.0}, ValueError, "`max_step` must be > 0"),
        ({"max_step": -1.0}, ValueError, "`max_step` must be > 0"),
        ({"first_step": 5.0}, ValueError, "`first_step` must be > 0 and at most"),
        ({"first_step": 1e-300}, ValueError, r"`first_step` = 1e-300 needs 1e\+300 steps"),
        ({"max_step": 1e-20}, ValueError, r"`max_step` = 1e-20 needs 1e\+20 steps over t_span"),
        ({"t_eval": [0.5, 0.2]}, ValueError, "`t_eval` must be strictly increasing"),
        ({"t_eval": [0.5, 2.0]}, ValueError, "`t_eval` must lie within"),
        ({"t_eval": []}, ValueError, "`t_eval` must hold"),
        ({"t_eval": ["a"]}, TypeError, "`t_eval` must be a sequence"),
        ({"events": 3}, TypeError, "`events` must be"),
        ({"events": [lambda t, x: 0.0, "x"]}, TypeError, "item 1"),
        ({"dense_output": "yes"}, TypeError, "`dense_output`"),
        ({"args": (1.0, 2.0, 3.0, 4.0)}, ValueError, "`args` must have 3 values"),
        ({"save_every": 10}, ValueError, "`save_every` must be 1 or None with adaptive"),
        ({"checkpoint": ("x.npz", 10)}, ValueError, "`checkpoint` and `resume`"),
    ],
)
def test_every_new_keyword_is_validated_by_name(kwargs, error, match):
    kwargs = dict(kwargs)
    h = kwargs.pop("h", None)
    with pytest.raises(error, match=match):
        geomint.solve(BODY, M0, (0.0, 1.0), h, **kwargs)


def test_a_max_step_that_cannot_advance_the_time_is_refused_before_the_run():
    """At t = 1e6 the float64 spacing is 1.2e-10: a bound of 1e-12 on the step would never move t (the run
    used to spin without end), so it is refused as a fixed h is."""
    with pytest.raises(ValueError, match=r"`max_step` = 1e-12 cannot advance the time 1000001.0 in float64"):
        geomint.solve(BODY, M0, (1e6, 1e6 + 1.0), max_step=1e-12, save_every=None)
    with pytest.raises(ValueError, match=r"`max_step` = 1e-12 cannot advance"):
        geomint.solve_ensemble(BODY, [M0, M0], (1e6, 1e6 + 1.0), max_step=1e-12)
    assert geomint.solve(BODY, M0, (1e6, 1e6 + 1.0), max_step=1e-3, save_every=None).success


def test_an_event_that_raises_or_is_not_finite_is_named():
    def bad(t, x):
        return float("nan")

    with pytest.raises(ValueError, match=r"`events\[0\]` \(bad\) returned nan"):
        geomint.solve(BODY, M0, (0.0, 1.0), events=bad)

    def nothing(t, x):
        return None

    with pytest.raises(ValueError, match=r"`events\[0\]` \(nothing\) returned None at t = 0.0"):
        geomint.solve(BODY, M0, (0.0, 1.0), events=nothing)

    def raising(t, x):
        raise ZeroDivisionError("no")

    with pytest.raises(geomint.UserFunctionError, match=r"events\[0\] \(raising\)` raised ZeroDivisionError"):
        geomint.solve(BODY, M0, (0.0, 1.0), events=raising)
    with pytest.raises(ValueError, match="terminal"):

        def count(t, x):
            return x[0]

        count.terminal = -2
        geomint.solve(BODY, M0, (0.0, 1.0), events=count)
