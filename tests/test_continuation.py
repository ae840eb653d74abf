"""geomint.continuation: equilibria followed in eps, changes located against closed forms."""

import numpy as np
import pytest

import geomint
from geomint.analysis.continuation import continuation

EPS_VALUES = [0.0, 0.01, 0.1, 1.0, 10.0]


def _branch(result, x):
    return min(result.branches, key=lambda b: np.linalg.norm(b.x - np.asarray(x)))


def test_rigid_body_poles_turn_from_centres_to_foci_at_zero_and_to_nodes_at_the_closed_form_eps():
    a, b, c, H0 = 0.5, 1.0, 1.5, 0.6471252793138366
    result = continuation(geomint.systems.relaxing_rigid_body(a, b, c), H0, EPS_VALUES, n=600)
    assert len(result.branches) == 6 and all(br.displacement < 1e-12 for br in result.branches)
    z0, x0 = np.sqrt(2 * H0 / c), np.sqrt(2 * H0 / a)
    # tangent-plane matrix at the pole (0, 0, z0): z0 [[eps c z0 (a - c), b - c], [c - a, eps c z0 (b - c)]];
    # its discriminant vanishes at eps* = 2 sqrt((c - a)(c - b)) / (c z0 |b - a|)
    for x, coefficient, others, verdict in (([0, 0, z0], c, (a, b), "stable"), ([x0, 0, 0], a, (b, c), "unstable")):
        branch = _branch(result, x)
        p, q = others
        expected = 2 * np.sqrt((coefficient - p) * (coefficient - q)) / (coefficient * np.linalg.norm(x) * abs(q - p))
        assert [str(ch).split(" at ")[0] for ch in branch.changes] == [
            f"neutral/centre -> {verdict}/focus",
            f"{verdict}/focus -> {verdict}/node",
        ]
        assert branch.changes[0].at_zero
        assert branch.changes[1].eps == pytest.approx(expected, rel=1e-6)
        assert branch.verdicts.tolist() == ["neutral"] + [verdict] * 4
    saddle = _branch(result, [0, np.sqrt(2 * H0 / b), 0])
    assert saddle.changes == [] and set(saddle.kinds) == {"saddle"}


def test_degenerate_example_1_verdicts_are_fixed_as_soon_as_eps_is_positive():
    result = continuation(geomint.systems.degenerate_example(1), 0.5, EPS_VALUES, n=600)
    plus, minus, pole = (_branch(result, x) for x in ([1, 0, 0], [-1, 0, 0], [0, 0, 1]))
    assert plus.verdicts.tolist() == ["neutral"] + ["stable"] * 4 and plus.kinds[0] == "degenerate"
    assert minus.verdicts.tolist() == ["unstable"] * 5 and minus.kinds[1:].tolist() == ["saddle"] * 4
    assert pole.verdicts.tolist() == ["neutral"] + ["unstable"] * 4
    assert all(ch.at_zero for br in result.branches for ch in br.changes)
    # eigenvalues at (r, 0, 0): (-r, -eps r^2) on the unit sphere
    np.testing.assert_allclose(
        plus.eigenvalues.real,
        np.stack([np.minimum(-1.0, -np.array(EPS_VALUES)), np.maximum(-1.0, -np.array(EPS_VALUES))], 1),
        atol=1e-6,
    )


def test_oscillator_equator_cycle_exponent_is_linear_in_eps():
    result = continuation(geomint.systems.dissipative_oscillator((0.0, 0.0, 1.0)), 0.5, EPS_VALUES, n=600)
    [cycle] = [b for b in result.branches if b.object == "cycle"]
    np.testing.assert_allclose(cycle.eigenvalues[:, 1].real, -2.0 * np.array(EPS_VALUES), rtol=1e-6, atol=1e-9)
    assert cycle.verdicts.tolist() == ["neutral"] + ["stable"] * 4
    assert len(result.rows()) == 3


@pytest.mark.parametrize(
    "eps_values, error, message",
    [
        ([1.0], ValueError, r"`eps_values` must be a 1-D sequence of at least 2 values"),
        ([0.0, 2.0, 1.0], ValueError, r"`eps_values` must be finite, increasing and >= 0; got \[0.0, 2.0, 1.0\]"),
        ([-1.0, 1.0], ValueError, r"`eps_values` must be finite, increasing and >= 0"),
        (["a", "b"], TypeError, r"`eps_values` must be a sequence of real numbers"),
    ],
)
def test_bad_eps_values_are_refused(eps_values, error, message):
    with pytest.raises(error, match=message):
        continuation(geomint.systems.relaxing_rigid_body(), 0.75, eps_values)
