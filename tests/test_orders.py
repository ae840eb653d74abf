"""Measured orders of accuracy match the declared ones."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import geomint
from geomint.testing import observed_order

STEPS = [0.2, 0.1, 0.05, 0.025, 0.0125]
CASES = {
    "relaxing_rigid_body": (
        geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.5),
        [np.cos(1.1), 0.0, np.sin(1.1)],
    ),
    "quartic_rigid_body": (geomint.systems.quartic_rigid_body(0.5, 1.0, 1.5, k=0.5, eps=0.5), [0.6, 0.3, 0.7]),
}
T_END = 2.0


def _reference(system, x0):
    sol = solve_ivp(lambda t, x: system.xi(x), (0.0, T_END), x0, method="DOP853", rtol=1e-13, atol=1e-15)
    return sol.y[:, -1]


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("method", [geomint.Gonzalez(), geomint.RK4()], ids=lambda m: m.name)
def test_observed_order_matches_the_declared_order(case, method):
    system, x0 = CASES[case]
    exact = _reference(system, x0)
    errors = [np.max(np.abs(geomint.solve(system, x0, (0.0, T_END), h, method=method).x_final - exact)) for h in STEPS]
    order = observed_order(STEPS, errors)
    print(f"{case} {method.name}: errors {['%.2e' % e for e in errors]} -> order {order:.3f}")
    assert abs(order - method.order) <= 0.1


def test_observed_order_drops_the_round_off_plateau():
    h = np.array([0.1, 0.05, 0.025, 0.0125, 0.00625])
    errors = np.maximum(h**4, 1e-14)  # the last point is on the plateau
    assert observed_order(h, errors) == pytest.approx(4.0, abs=1e-9)
    with pytest.raises(ValueError, match="`step_sizes` must give >= 3 errors"):
        observed_order(h, np.full(5, 1e-15))
