"""geomint.plotting on plain Solutions: every function draws a key per line and counts failures and rises."""

import numpy as np
import pytest

import geomint
from geomint import diagnostics, plotting, studies

BODY = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
X0 = [np.cos(1.1), 0.0, np.sin(1.1)]


@pytest.fixture(scope="module")
def runs():
    return [geomint.solve(BODY, X0, (0.0, 20.0), 0.1, method=m) for m in ("gonzalez", "rk4", "yoshida4")]


def _labels(ax):
    return ax.get_legend_handles_labels()[1]


def test_twenty_methods_get_twenty_distinct_styles():
    styles = [plotting.style(i, 20) for i in range(20)]
    assert len({(s["color"], s["linestyle"]) for s in styles}) == 20
    assert len({(s["color"], s["marker"]) for s in styles}) == 20  # also when a caller sets the line styles


def test_energy_error_keys_every_method_and_reports_the_worst(runs):
    ax = plotting.energy_error(runs)
    assert _labels(ax) == ["gonzalez", "rk4", "yoshida4", "1 ulp (machine epsilon)"]
    worst = max(s.energy_error for s in runs)
    assert ax.get_title().endswith(f"= {worst:.2g} ({worst / diagnostics.EPS:.3g} ulp)")  # ulp, never "eps"


def test_casimir_marks_and_counts_S_rises():
    n = 5
    sol = geomint.Solution(
        t=np.arange(n, dtype=float),
        x=np.zeros((n, 3)),
        H=np.ones(n),
        S=np.array([3.0, 2.0, 2.5, 1.0, 0.5]),
        success=True,
        status=0,
        message="",
        failed_step=None,
        n_steps=n - 1,
        n_newton=0,
        nfev=0,
        method=geomint.RK4(),
    )
    ax = plotting.casimir(sol)
    assert ax.get_title() == "Casimir S: 1 rise beyond round-off"
    assert "S rose (beyond 16 ulps)" in _labels(ax)


def test_drift_labels_the_growth_law():
    free = geomint.systems.relaxing_rigid_body(eps=0.0)
    sols = [geomint.solve(free, X0, (0.0, 1000.0), 0.2, method=m, save_every=5) for m in ("gonzalez", "rk4")]
    labels = _labels(plotting.drift(sols))
    assert labels[1].startswith("rk4: t (p = ") and labels[0].split(":")[0] == "gonzalez"
    # Gonzalez keeps H within a few ulp: no law is fitted to round-off (issue 26 saw "sqrt t (p = 0.44)")
    assert labels[0] == "gonzalez: at round-off (within 16 ulp), no growth law"


def test_level_surface_counts_failures_in_the_title_and_marks_them():
    starts = geomint.level_set.sample(BODY, 0.6, 3)
    sols = [geomint.solve(BODY, x, (0.0, 2.0), 0.5, method=geomint.Gonzalez(max_newton_iter=1)) for x in starts]
    ok = geomint.solve(BODY, starts[0], (0.0, 2.0), 0.1)
    ax = plotting.level_surface(BODY, sols + [ok])
    assert ax.get_title() == "trajectories on H = 0.6; 3 of 4 failed"
    assert "failed: last state reached (3)" in _labels(ax)
    assert sum(label.startswith("x0 = (") for label in _labels(ax)) == 4


def test_level_surface_on_an_unbounded_level_set_fits_the_trajectories():
    cylinder = geomint.MetriplecticSystem.from_expressions(
        H="(y**2 + z**2)/2 - r*z",
        S="x**2/2 - sigma*z",
        J=("-x", "0", "sigma"),
        params={"sigma": 10.0, "r": 28.0},
        eps=0.002,
    )
    sol = geomint.solve(cylinder, [-2.0, 3.0, 20.0], (0.0, 2.0), 0.002)
    ax = plotting.level_surface(cylinder, sol)
    span = max(np.ptp(sol.x, axis=0))
    for low, high in (ax.get_xlim(), ax.get_ylim(), ax.get_zlim()):
        assert high - low <= 1.5 * span


def test_level_surface_draws_a_circle_of_equilibria_as_a_curve():
    equal = geomint.systems.relaxing_rigid_body(1.0, 1.0, 0.5, eps=0.5)
    sol = geomint.solve(equal, [0.3, 0.2, 0.6], (0.0, 5.0), 0.05)
    ax = plotting.level_surface(equal, sol)
    # The circle x² + y² = 2 H0 attracts at rate -1.5 eps across it (geomint.analysis), so it is drawn as stable.
    assert "curve of stable equilibria" in _labels(ax)


def test_work_precision_draws_one_keyed_line_per_curve():
    reference = studies.reference_solution(BODY, X0, 1.0)
    curves = [studies.work_precision(BODY, X0, 1.0, m, [5, 10, 20], reference, repeats=1) for m in ("gonzalez", "rk4")]
    ax = plotting.work_precision(curves, cost="nfev")
    assert _labels(ax) == ["gonzalez", "rk4"]
    assert [line.get_linestyle() for line in ax.get_lines()] == ["-", "--"]
    with pytest.raises(ValueError, match=r"`cost` must be \"wall\" or \"nfev\"; got 'time'"):
        plotting.work_precision(curves, cost="time")


def test_the_title_lists_every_energy_level_and_says_which_surfaces_are_drawn():
    """Issue 26: four levels, the title listed three."""
    starts = [[0.6, 0.0, 0.8], [0.0, 0.5, 0.5], [0.3, 0.3, 0.3], [0.9, 0.1, 0.1]]
    sols = [geomint.solve(BODY, x, (0.0, 0.5), 0.1) for x in starts]
    levels = ", ".join(f"{float(sol.H[0]):.4g}" for sol in sols)
    assert plotting.level_surface(BODY, sols).get_title() == f"trajectories on H = {levels} (surfaces of the first 3)"
    many = [geomint.solve(BODY, [0.1 * k, 0.2, 0.3], (0.0, 0.2), 0.1) for k in range(1, 7)]
    energies = [float(sol.H[0]) for sol in many]
    assert plotting.level_surface(BODY, many).get_title() == (
        f"trajectories on 6 levels of H from {min(energies):.4g} to {max(energies):.4g} (surfaces of the first 3)"
    )


def test_an_unbounded_level_set_is_meshed_in_a_box_not_by_rays():
    """Issue 26: a cylinder drawn by rays from a centre was a lumpy blob; marching tetrahedra in a box give the
    cylinder itself, end to end of the box, its vertices on H = H0."""
    cylinder = geomint.MetriplecticSystem.from_expressions(H="(y**2 + z**2)/2", S="x**2/2 + z", J=("x", "0", "1"))
    low, high = np.array([-2.0, -1.5, -1.5]), np.array([2.0, 1.5, 1.5])
    triangles = geomint.level_set.isosurface(cylinder, 0.5, low, high)
    vertices = triangles.reshape(-1, 3)
    assert len(triangles) > 1000
    np.testing.assert_allclose(np.hypot(vertices[:, 1], vertices[:, 2]), 1.0, rtol=1e-4)
    assert np.all((vertices >= low - 1e-9) & (vertices <= high + 1e-9))
    assert vertices[:, 0].min() == pytest.approx(-2.0) and vertices[:, 0].max() == pytest.approx(2.0)
    areas = 0.5 * np.linalg.norm(np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]), axis=1)
    assert areas.sum() == pytest.approx(2 * np.pi * 4.0, rel=0.02)  # the lateral area 2 pi r L of the cylinder


def _blank_columns(path):
    """Fractions of the image's width: the widest band of columns with nothing drawn, and the band after the
    last drawn column."""
    import matplotlib.image

    blank = np.all(matplotlib.image.imread(path)[..., :3] > 0.98, axis=(0, 2))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], blank.astype(int), [0]])))
    widest = max(np.diff(edges.reshape(-1, 2), axis=1).max(initial=0), 0)
    return widest / len(blank), (len(blank) - 1 - np.flatnonzero(~blank).max()) / len(blank)


def test_scene_figures_leave_no_empty_band_beside_their_key(tmp_path):
    """Issue 26: the key sat far to the right with ~15 % of the width empty (before: bands of 7.5 % between the
    panels and the key of the overview and 4.7 % after it; 7.3 % after the key of the drift figure); the key now
    sits beside the panels and the figure is cropped to it."""
    from geomint.scene import Scene, run_scene

    scene = Scene(
        system="relaxing_rigid_body",
        points=[[0.6, 0.0, 0.8], [0.0, 0.6, 0.8]],
        h=0.1,
        duration=2.0,
        eps=0.5,
        figures=("overview", "trajectories", "invariants", "drift"),
        every=1,
    )
    for path in plotting.draw(run_scene(scene), tmp_path):
        widest, after = _blank_columns(path)
        assert widest < 0.05 and after < 0.03, (path.name, widest, after)
