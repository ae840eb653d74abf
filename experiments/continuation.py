"""Stability of equilibria and rest cycles as eps grows from 0: writes docs/continuation.md and its figures.

    PYTHONPATH=. python -m experiments.continuation

The paper's closing remark asks which bifurcations the parameter eps of
``dx/dt = xi_P + eps xi_g`` brings to the stability of equilibria.  This
follows every equilibrium, curve of equilibria and rest cycle (``dS = 0``) of
the paper's systems with ``geomint.continuation`` over ``eps`` in
``{0} u [1e-3, 10]`` and reports every change of verdict or kind; then runs
the scene ``experiments/scenes/oscillator_double_well.toml`` (the case where
something does bifurcate, in H0) and draws it.
"""

import time
from pathlib import Path

import numpy as np

import geomint
from geomint.analysis.continuation import continuation
from geomint.plotting import continuation_figure, draw

from .report import DOCS, markdown_table

EPS_VALUES = np.concatenate([[0.0], np.geomspace(1e-3, 10.0, 41)])
SHOWN_EPS = (0.1, 1.0, 10.0)
SCENE = Path(__file__).resolve().parent / "scenes" / "oscillator_double_well.toml"
DOUBLE_WELL = (0.0, 0.0, -0.5, 0.0, 0.25)  # S = z^4/4 - z^2/2: S' = z (z^2 - 1)

CASES = [
    (
        "relaxing rigid body, (a, b, c) = (0.5, 1, 1.5)",
        geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5),
        0.6471252793138366,
    ),
    ("relaxing rigid body, a = b: (1.5, 1.5, 0.5)", geomint.systems.relaxing_rigid_body(1.5, 1.5, 0.5), 0.75),
    ("dissipative oscillator, S = z^2", geomint.systems.dissipative_oscillator((0.0, 0.0, 1.0)), 0.5),
    ("dissipative oscillator, S = z^4/4 - z^2/2, r = 0.8", geomint.systems.dissipative_oscillator(DOUBLE_WELL), 0.32),
    ("dissipative oscillator, S = z^4/4 - z^2/2, r = 1.2", geomint.systems.dissipative_oscillator(DOUBLE_WELL), 0.72),
    ("degenerate Example 1", geomint.systems.degenerate_example(1), 0.5),
    ("degenerate Example 2", geomint.systems.degenerate_example(2), 1.3),
]

NOTE = """## What was found

**Equilibria do not move with eps.** For eps > 0, xi = 0 exactly where xi_P = 0 and xi_g = 0 (the two parts are
orthogonal, Lemma 6), a condition free of eps; every branch above was re-solved at every eps and moved by at most
{displacement:.1e}. Only the eigenvalues change.

**Stability changes only at eps = 0+.** Every regular equilibrium is a centre or a saddle of the Hamiltonian system at
eps = 0 (neutral or unstable). As soon as eps > 0 the centres become stable or unstable foci, the saddles stay
saddles, and from then on no verdict changes over [1e-3, 10]: no eigenvalue crosses the imaginary axis at any
eps > 0, in none of the systems. The reason is visible in closed form. At the pole (0, 0, z0) of the rigid body the
tangent-plane matrix is z0 [[eps c z0 (a - c), b - c], [c - a, eps c z0 (b - c)]], with trace eps c z0^2 (a + b - 2c)
and determinant z0^2 (c - a)(c - b)(1 + eps^2 c^2 z0^2): the sign of the determinant does not depend on eps, and the
trace is eps times a fixed number, so the verdict is fixed for every eps > 0 — stable on the axis of the largest
coefficient, unstable on the smallest, a saddle on the middle one, as the paper states for eps = 1. For the
oscillator the poles have eigenvalues eps r S'(+-r) +- i and a rest cycle at z0 (S'(z0) = 0) has Floquet exponent
-eps rho^2 S''(z0): again eps times a fixed number. In the degenerate examples the linearisations at (+-r0, 0, 0) are
diag(-+r0, -eps r0^2) (Example 1): eps only turns a zero eigenvalue into a negative one.

**What does change with eps** is the kind: the rigid body's foci become nodes where the discriminant
eps^2 c^2 z0^4 (b - a)^2 - 4 z0^2 (c - a)(c - b) vanishes, at eps* = 2 sqrt((c - a)(c - b)) / (c z0 |b - a|) for the
pole on the c axis (measured: {rigid_body_changes}). This is a change of the way trajectories approach the pole
(spiralling, then not), not of stability.

**Something does bifurcate — in H0, not in eps.** With S = z^4/4 - z^2/2 the poles of the sphere of radius r have
eigenvalues eps r S'(r) +- i, S'(r) = r (r^2 - 1): on r = 0.8 the poles are stable foci and the equator (S''(0) < 0) a
repelling cycle; on r = 1.2 the poles are unstable and two attracting cycles at z = +-1 (S''(+-1) = 2 > 0) have
appeared between them — they are born from the poles as r passes 1, where the rest leaves z = +-1 first touch the
level set (a degenerate Hopf bifurcation in the level-set parameter; eps only scales the rates).

**Why, in general.** The closed forms above are one instance of a factorisation that holds at every regular
equilibrium with grad S = lam grad H != 0, in any system of this form (`geomint.analysis.factorise`, tested on the
rigid bodies, the quartic and coupled bodies and the oscillator). Write J = mu grad S (S is a Casimir) and
L = Hess S - lam Hess H, the Hessian of the Lagrangian of S on H = H0. Where grad H x grad S = 0, linearising
xi_P = mu grad H x grad S and xi_g = grad H x (grad H x grad S) gives, on the tangent plane,

    J_T(eps) = (mu C_T - eps |grad H|^2 I) L_T,

with C_T = [grad H x] restricted to the tangent plane (|grad H| times a rotation by a right angle) and L_T the
restricted Lagrangian Hessian. Hence det J_T = |grad H|^2 (mu^2 + eps^2 |grad H|^2) det L_T and
tr J_T = -eps |grad H|^2 tr L_T: the sign of the determinant never depends on eps and the trace is eps times a fixed
number. At eps = 0 a constrained extremum of S is a centre and a constrained saddle a saddle; for every eps > 0 a
minimum of S on H = H0 is stable, a maximum unstable, a saddle a saddle. Foci turn into nodes at
eps* = 2 |mu| sqrt(l1 l2) / (|grad H| |l1 - l2|) (l1, l2 the eigenvalues of L_T), which is the rigid body's eps*.

**Answer to the paper's remark, for these systems:** the family dx/dt = xi_P + eps xi_g has no bifurcation of
equilibria at any eps > 0; the only change of stability happens at eps = 0, where the neutral Hamiltonian centres
(and the degenerate equilibria of the non-regular examples) acquire the stability of the critical point of S on the
level set (Prop. 11 to second order: the dissipative part is the gradient flow of S restricted to H = H0, and it
commutes in the above sense with the Hamiltonian rotation). By the factorisation the same holds at every
non-degenerate regular equilibrium with grad S || grad H of any system built this way; bifurcations can only come
from degenerate points (det L_T = 0, as the double well at r = 1, where they happen in H0), from equilibria with
dS = 0 or at non-regular points, or from an eps-dependent H or S, which the construction excludes.
"""


def run():
    results, seconds = [], []
    for label, system, H0 in CASES:
        start = time.perf_counter()
        results.append((label, continuation(system, H0, EPS_VALUES)))
        seconds.append(time.perf_counter() - start)
        print(f"{label}: {len(results[-1][1].branches)} branches in {seconds[-1]:.1f} s", flush=True)
    return results, seconds


def _eigenvalue_cell(branch, eps):
    k = int(np.argmin(np.abs(branch.eps - eps)))
    lam = branch.eigenvalues[k]
    if branch.object != "equilibrium":
        return f"{lam[1].real:.4g}" + (" (across)" if branch.object == "curve" else "")
    return ", ".join(f"{z.real:.4g}{z.imag:+.4g}i" if abs(z.imag) > 1e-9 else f"{z.real:.4g}" for z in lam)


def tables(results):
    rows = []
    for label, result in results:
        for branch in result.branches:
            changes = "; ".join(str(c) for c in branch.changes) or "none"
            rows.append(
                [label, branch.label.replace("|", "\\|"), f"{branch.verdicts[0]} {branch.kinds[0]}"]
                + [_eigenvalue_cell(branch, eps) for eps in SHOWN_EPS]
                + [f"{branch.verdicts[-1]} {branch.kinds[-1]}", changes]
            )
    headers = (
        ["system, level set", "branch", "eps = 0"]
        + [f"eigenvalues at eps = {e:g}" for e in SHOWN_EPS]
        + ["eps = 10", "changes"]
    )
    return markdown_table(headers, rows)


def main():
    results, seconds = run()
    continuation_figure([r for _, r in results], DOCS / "continuation.png")
    [scene_figure] = draw(geomint.run_scene(geomint.Scene.from_toml(SCENE)), DOCS)
    displacement = max(b.displacement for _, r in results for b in r.branches)
    top = [b for b in results[0][1].branches if b.object == "equilibrium"]
    rigid_body_changes = "; ".join(
        sorted({f"{b.label.split(' at ')[1]}: {c}" for b in top for c in b.changes if not c.at_zero})
    )
    text = "\n\n".join(
        [
            "# Stability against eps: continuation of equilibria and rest cycles",
            f"Generated by `PYTHONPATH=. python -m experiments.continuation` in {sum(seconds):.0f} s "
            f"(`geomint.continuation.continuation` over {len(EPS_VALUES)} values of eps: 0 and 41 from 1e-3 to 10). "
            "Eigenvalues are those of the linearisation restricted to the tangent plane of H = H0 "
            "(`geomint.analysis.linearise`); for a curve of equilibria the one across it, for a rest cycle its Floquet "
            'exponent. "0+": the change happens as soon as eps > 0 (below the resolution of the linearisation). '
            "Changes of kind (focus to node) are bisected to the last digit shown.",
            "![Real parts of the eigenvalues against eps](continuation.png)",
            "Solid and dashed: the two eigenvalues of an equilibrium (mirror-image equilibria overlap); dotted: the "
            "Floquet exponent of a rest cycle; vertical lines: changes of kind at eps > 0.",
            tables(results),
            f"The double-well case simulated (`geomint run experiments/scenes/{SCENE.name}`): trajectories from ten "
            "starts on the sphere of radius 1.2 wind onto the cycles at z = +-1; H is kept to round-off and S never "
            f"rises.\n\n![Double-well oscillator scene]({scene_figure.name})",
            NOTE.format(displacement=displacement, rigid_body_changes=rigid_body_changes),
        ]
    )
    (DOCS / "continuation.md").write_text(text + "\n")
    print(f"wrote {DOCS / 'continuation.md'}")


if __name__ == "__main__":
    main()
