"""Fuzzing the front door: every call of ``solve`` or of a constructor ends in a result or in a
TypeError/ValueError that names the argument, never in another exception or a result with a NaN."""

import re

import numpy as np
from hypothesis import event, given
from hypothesis import strategies as st

import geomint

BODY = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
OSCILLATOR = geomint.systems.dissipative_oscillator(eps=1.0)
NAMED = re.compile(r"`[A-Za-z_][A-Za-z_0-9\[\]'.]*`")

#: values of every kind a caller may pass by mistake (or on purpose at the edges of float64)
JUNK = [
    None,
    True,
    False,
    "0.1",
    "abc",
    b"1",
    [],
    [0.1],
    (0.1, 0.2),
    {"h": 1},
    object(),
    np.nan,
    np.inf,
    -np.inf,
    0,
    -1,
    10**400,
    -(10**400),
    1e-320,
    5e-324,
    1e308,
    np.float32(0.1),
    np.int64(3),
    np.array(0.1),
    np.array([0.1, 0.2]),
    complex(1, 1),
]
#: values that are no real number at all
NOT_REAL = [None, True, "0.1", b"1", [], [0.1], {"h": 1}, object(), complex(1, 1), np.array([0.1, 0.2])]
REALS = [0.1, 1e-3, 1.0, 2.5]

#: for each argument of ``solve``: values that are valid (some at the edges of float64, where a run may
#: still fail with a status), and values that are not
VALID = dict(
    system=[BODY, OSCILLATOR],
    x0=[
        [np.cos(1.1), 0.0, np.sin(1.1)],
        [1e150] * 3,
        [1e-320, 0.0, 1e-320],
        [1e-300] * 3,
        [0.0] * 3,
        np.array([1, 2, 3]),
        [1, 2, 3],
        (0.3, -0.2, 5.0),
    ],
    t_span=[
        (0.0, 1.0),
        [0, 1],
        np.array([0.0, 2.0]),
        (-1.0, 1.0),
        (1e10, 1e10 + 1.0),
        (0.0, 1e-3),
        (1.0, 0.0),
        (0.0, -0.5),
    ],
    h=REALS + [np.float32(0.1), np.int64(1), 1e-3],
    method=[
        "gonzalez",
        "rk4",
        "yoshida4",
        "projected",
        "strang",
        "avf",
        "itoh_abe",
        "damped_gonzalez",
        geomint.Gonzalez(max_newton_iter=1),
        geomint.Projected(geomint.AVF()),
        geomint.Yoshida4(geomint.SymmetrizedItohAbe()),
        geomint.KahanLi8(geomint.Gonzalez()),
        None,
    ],
    save_every=[1, 3, None, 10**30, np.int64(2)],
    progress=[None, lambda n: None],
)
BAD = dict(
    system=["body", None, 3, geomint.Gonzalez()],
    x0=[
        [1e200] * 3,
        [np.nan, 0.0, 0.0],
        [1.0, 2.0],
        [[1.0, 2.0, 3.0]],
        "abc",
        [True, 0, 0],
        ["1", "2", "3"],
        np.zeros((3, 1)),
        [10**400, 0, 0],
        0.5,
    ]
    + NOT_REAL,
    t_span=[
        (0.0, 0.0),
        (0.0, np.inf),
        "01",
        (0.0,),
        (0.0, 1.0, 2.0),
        (1e16, 1e16 + 2),
        (True, 2.0),
        (0, 10**400),
        (np.nan, 1.0),
        ("0", "1"),
        0.5,
    ]
    + NOT_REAL[:-1],
    h=[np.nan, np.inf, -np.inf, 0, -1, 10**400, -(10**400), 1e-320, 5e-324] + NOT_REAL,
    method=["nope", 3, geomint.RK4, "rigid_body_flow", "oscillator_rotation", ""],
    save_every=[0, -1, 2.5, 1.0, True, "1", np.nan, np.inf, -(10**400), [1], object()],
    progress=[5, "x", 1.5],
)


def _outcome(call):
    """The result of ``call()``; a TypeError/ValueError must name an argument in backticks."""
    try:
        return call()
    except (TypeError, ValueError) as error:
        assert NAMED.search(str(error)), f"the error does not name the argument: {error!r}"
        return None


@given(st.data())
def test_solve_ends_in_a_result_or_an_error_naming_the_argument(data):
    """Up to two arguments replaced by invalid values, the others valid (edge values included)."""
    bad = data.draw(st.sets(st.sampled_from(sorted(VALID)), max_size=2), label="invalid arguments")
    kwargs = {name: data.draw(st.sampled_from(BAD[name] if name in bad else VALID[name]), label=name) for name in VALID}
    sol = _outcome(lambda: geomint.solve(**kwargs))
    event("a result" if sol is not None else "an error")
    if sol is not None:
        event(f"status {sol.status}")
        assert not bad, f"accepted invalid {sorted(bad)}"
        assert sol.status in (0, -1, -2, -3, -4)
        assert sol.success == (sol.status == 0)
        for name in ("t", "x", "H", "S"):
            assert np.all(np.isfinite(getattr(sol, name))), name
        assert np.isfinite(sol.energy_error)
        assert np.all(np.diff(sol.t) * np.sign(kwargs["t_span"][1] - kwargs["t_span"][0]) > 0)


@given(
    value=st.sampled_from(REALS + JUNK + [[0.0, 1.0], ["1"], [1, [2]], np.ones((2, 2))]),
    eps=st.sampled_from(REALS + JUNK),
)
def test_catalogue_constructors_end_in_a_system_or_an_error_naming_the_argument(value, eps):
    systems = geomint.systems
    for build in (
        lambda: systems.relaxing_rigid_body(value, 1.0, 1.5, eps=eps),
        lambda: systems.quartic_rigid_body(k=value, eps=eps),
        lambda: systems.dissipative_oscillator(coefficients=value, eps=eps),
        lambda: systems.degenerate_example(number=value, eps=eps),
    ):
        system = _outcome(build)
        if system is not None:
            assert np.isfinite(system.eps) and np.all(np.isfinite(system.params))


@given(
    H=st.sampled_from([BODY.functions.H, "x", None, 3, np.sin, lambda x, p: 1.0]),
    eps=st.sampled_from(REALS + JUNK),
    params=st.sampled_from(["catalogue", [1.0, 2.0]] + JUNK),
    check=st.sampled_from([True, False, "yes", None]),
)
def test_the_system_constructor_ends_in_a_system_or_an_error_naming_the_argument(H, eps, params, check):
    f = BODY.functions
    _outcome(
        lambda: geomint.MetriplecticSystem(
            H=H,
            grad_H=f.grad_H,
            S=f.S,
            grad_S=f.grad_S,
            J=f.poisson,
            params=BODY.params if isinstance(params, str) and params == "catalogue" else params,
            eps=eps,
            check=check,
        )
    )


@given(
    option=st.sampled_from([1, 50, 10**6] + JUNK),
    compensated=st.sampled_from([True, False] + JUNK),
    scheme=st.sampled_from(["yoshida4", "kahan_li8", ["x"], [0.5, 0.5], (1.0,), []] + JUNK),
    base=st.sampled_from([geomint.Gonzalez(), geomint.RK4(), geomint.Strang(geomint.Gonzalez(), geomint.AVF())] + JUNK),
)
def test_integrator_constructors_end_in_an_integrator_or_an_error_naming_the_argument(
    option, compensated, scheme, base
):
    _outcome(lambda: geomint.Gonzalez(max_newton_iter=option, compensated=compensated))
    _outcome(lambda: geomint.Composition(base=base, scheme=scheme))
    _outcome(lambda: geomint.Projected(base))
    _outcome(lambda: geomint.Strang(base, option))


def test_a_bool_beside_numbers_is_no_coordinate():
    """Found by the fuzz test above: ``[True, 0, 0]`` became the state (1, 0, 0)."""
    for x0 in ([True, 0, 0], [0.1, np.True_, 0.2]):
        error = _outcome_error(lambda: geomint.solve(BODY, x0, (0.0, 0.1), 0.05))
        assert isinstance(error, TypeError) and "`x0`" in str(error)
        error = _outcome_error(lambda: geomint.solve_ensemble(BODY, [x0, [1.0, 0.0, 0.0]], (0.0, 0.1), 0.05))
        assert isinstance(error, TypeError) and "`X0`" in str(error) or "`x0`" in str(error)


def _outcome_error(call):
    try:
        call()
    except (TypeError, ValueError) as error:
        return error
    return None
