"""The engine's shape (issue 10): kernel modules without import cycles, compile only what a run uses,
any method as a stage of a splitting, composition or projection, exact flows declared by systems,
and the integrator protocol read from instances."""

import ast
import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import geomint
from geomint.testing import observed_order

KERNELS = Path(geomint.__file__).parent / "_kernels"


def test_kernel_modules_import_each_other_without_a_cycle():
    """The graph of relative imports between kernel modules is acyclic (a topological order exists)."""
    graph = {}
    for path in KERNELS.glob("*.py"):
        tree = ast.parse(path.read_text())
        graph[path.stem] = {
            node.module
            for node in ast.walk(tree)
            if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module
        } | {
            alias.name
            for node in ast.walk(tree)
            if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module is None
            for alias in node.names
        }
    order, done = [], set()
    while len(done) < len(graph):
        ready = [m for m in graph if m not in done and graph[m] <= done | {m}]
        assert ready, (
            f"import cycle among {sorted(set(graph) - done)}: "
            f"{ ({m: sorted(graph[m]) for m in graph if m not in done}) }"
        )
        done.update(ready)
        order += sorted(ready)
    order.remove("__init__")
    # the entry points come last: the controllers, the one step loop, then the batch of step loops
    assert order[0] in ("borrow", "jit", "layout", "vec3") and order[-3:] == ["control", "loop", "batch"], order


COMPILED = """
import geomint
from geomint._kernels import composition, dg_step, discrete_field as dg, exact_flows, layout, runge_kutta
body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
def compiled():
    return [len(composition.composed_step.signatures), len(dg._FIELD_BY_CODE.signatures),
            len(dg._FIELDS[layout.GonzalezKind].signatures), len(dg._FIELDS[layout.AVFKind].signatures),
            len(runge_kutta.rk4_step.signatures), len(exact_flows.rigid_body_flow.signatures),
            len(dg_step.damping_factor.signatures)]
for method in ("gonzalez", geomint.Yoshida4(geomint.Gonzalez())):
    assert geomint.solve(body, [0.4536, 0.0, 0.8912], (0.0, 1.0), 0.05, method=method).success
    print(*compiled())
"""


@pytest.mark.slow
@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="compiled code only")
def test_a_run_compiles_only_the_steps_its_method_uses(tmp_path):
    """Counted on a cold compile (an empty numba cache: with a warm one nothing compiles and nothing could be
    seen).  A Gonzalez run compiles no composition, only Gonzalez's discrete field, no damping factor; a
    Yoshida4(Gonzalez()) run then adds the composition but still neither the discrete field of integer codes
    (the other discrete gradients), nor RK4, nor the exact flows."""
    out = subprocess.run(
        [sys.executable, "-c", COMPILED],
        capture_output=True,
        text=True,
        timeout=900,
        env={**os.environ, "GEOMINT_CACHE_DIR": str(tmp_path)},
    )
    assert out.returncode == 0, out.stderr
    gonzalez, yoshida = ([int(n) for n in line.split()] for line in out.stdout.splitlines())
    assert gonzalez == [0, 0, 1, 0, 0, 0, 0], out.stdout
    assert yoshida == [1, 0, 1, 0, 0, 0, 0], out.stdout


STEPS = [0.2, 0.1, 0.05, 0.025, 0.0125]


@pytest.mark.parametrize(
    "method",
    [
        geomint.Yoshida4(geomint.AVF()),
        geomint.Projected(geomint.AVF()),
        geomint.Strang(geomint.Gonzalez(), geomint.AVF()),
        geomint.Strang(geomint.RigidBodyFlow(), geomint.AVF()),
    ],
    ids=repr,
)
def test_any_method_is_a_stage_and_keeps_its_declared_order(method):
    """AVF (a method with coefficients of its own) composes, projects and splits, at the declared order."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.5)
    x0 = [np.cos(1.1), 0.0, np.sin(1.1)]
    exact = solve_ivp(lambda t, x: body.xi(x), (0.0, 2.0), x0, method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]
    errors = []
    for h in STEPS:
        sol = geomint.solve(body, x0, (0.0, 2.0), h, method=method)
        assert sol.success, sol.message
        errors.append(np.max(np.abs(sol.x_final - exact)))
    order = observed_order(STEPS, errors, floor=1e-12)
    print(f"{method!r}: order {order:.3f}")
    assert abs(order - method.order) <= 0.15


@numba.njit(cache=True)
def _H(m, p):
    return 0.5 * (0.3 * m[0] * m[0] + 0.9 * m[1] * m[1] + 2.0 * m[2] * m[2])


@numba.njit(cache=True)
def _grad_H(m, p):
    return (0.3 * m[0], 0.9 * m[1], 2.0 * m[2])


@numba.njit(cache=True)
def _S(m, p):
    return 0.5 * (m[0] * m[0] + m[1] * m[1] + m[2] * m[2])


@numba.njit(cache=True)
def _m(m, p):
    return (m[0], m[1], m[2])


def test_a_users_own_rigid_body_declares_and_runs_its_exact_flow():
    body = geomint.MetriplecticSystem(
        H=_H, grad_H=_grad_H, S=_S, grad_S=_m, J=_m, eps=0.2, exact_flows={"rigid_body_flow": (0.3, 0.9, 2.0)}
    )
    sol = geomint.solve(body, [0.6, 0.5, 0.4], (0.0, 50.0), 0.1, method=geomint.Strang(geomint.RigidBodyFlow()))
    assert sol.success, sol.message
    assert sol.energy_error < 1e-14 and sol.S_rises == 0
    undeclared = geomint.MetriplecticSystem(H=_H, grad_H=_grad_H, S=_S, grad_S=_m, J=_m, eps=0.2)
    with pytest.raises(ValueError, match="declare exact_flows"):
        geomint.solve(undeclared, [0.6, 0.5, 0.4], (0.0, 1.0), 0.1, method=geomint.Strang(geomint.RigidBodyFlow()))
    with pytest.raises(ValueError, match=r"hold for rigid_body_flow: grad H = \(a x, b y, c z\)"):
        geomint.MetriplecticSystem(
            H=_H, grad_H=_grad_H, S=_S, grad_S=_m, J=_m, exact_flows={"rigid_body_flow": (1, 1, 2)}
        )


def test_traits_are_instance_facts_and_the_cli_prints_them():
    for name, cls in geomint.integrators.INTEGRATORS.items():
        method = cls()
        assert isinstance(method.order, (int, float)) and isinstance(method.energy_exact, bool), name
    assert not geomint.Yoshida4().dissipative and geomint.Yoshida4(monotone=True).dissipative
    assert geomint.Strang(geomint.RigidBodyFlow(), geomint.Gonzalez()).order == 2
    assert geomint.Projected(geomint.Yoshida6()).order == 6 and geomint.Projected().energy_exact
    from io import StringIO

    from geomint.cli import list_all

    out = StringIO()
    list_all(out)
    assert "property object" not in out.getvalue() and "yoshida6                order 6" in out.getvalue()


def test_a_damped_stage_stays_damped_beside_undamped_stages_of_its_kind():
    """A program compiles the damping factor when any stage is damped (``ComposedStep.uses``), however its
    stages of the same discrete gradient are ordered: the damped gradient stage changes the step."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=5.0)
    x0 = [np.cos(1.1), 0.0, np.sin(1.1)]
    finals = {}
    for name, gradient_part in (("damped", geomint.DampedGonzalez()), ("undamped", geomint.Gonzalez())):
        method = geomint.Strang(geomint.Gonzalez(), gradient_part)
        sol = geomint.solve(body, x0, (0.0, 1.0), 0.1, method=method)
        assert sol.success, sol.message
        finals[name] = sol.x_final
    assert np.max(np.abs(finals["damped"] - finals["undamped"])) > 1e-6, finals


USES = [
    (geomint.Strang(geomint.Gonzalez(), geomint.AVF()), {"GonzalezKind", "AVFKind"}),
    (geomint.Lie(geomint.RigidBodyFlow(), geomint.Gonzalez()), {"RigidBodyFlowLeaf", "GonzalezKind"}),
    (geomint.Yoshida4(geomint.AVF()), {"AVFKind"}),
    # the monotone safeguard falls back on a Gonzalez step
    (geomint.Yoshida4(geomint.AVF(), monotone=True), {"AVFKind", "GonzalezKind"}),
    (geomint.Projected(geomint.RK4()), {"RK4Leaf"}),
    (geomint.Projected(geomint.Yoshida4(geomint.SymmetrizedItohAbe()), symmetric=True), {"SymmetrizedItohAbeKind"}),
    (geomint.Strang(geomint.Gonzalez(), geomint.DampedGonzalez()), {"GonzalezKind", "Damped"}),
    # damping scales eps, which the Hamiltonian flow does not have
    (geomint.Strang(geomint.DampedGonzalez(), geomint.Gonzalez()), {"GonzalezKind"}),
]


@pytest.mark.nojit
@pytest.mark.parametrize("method, expected", USES, ids=[repr(m) for m, _ in USES])
def test_a_program_lists_every_leaf_it_can_run(method, expected):
    """``ComposedStep.uses`` decides what the composition engine compiles: a leaf missing from it would not
    run (a row of the program lowered with another leaf's code), so every leaf a row can run is listed."""
    body = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
    assert {type(marker).__name__ for marker in method.lower(body).uses} == expected


BORROWED = """
import numpy as np
from numba.core.runtime import rtsys
import geomint
body, x0 = geomint.systems.relaxing_rigid_body(eps=0.1), [0.6, 0.0, 0.8]
gas, y0 = geomint.systems.gas_containers(), [1.5, 0.0, 2.0, 2.0]  # R^n, n = 4
for system, start, method in ((body, x0, geomint.Gonzalez()), (body, x0, geomint.RK4()), (gas, y0, geomint.Gonzalez())):
    X = np.array([start, np.roll(start, 1), np.roll(start, 2)])
    geomint.solve(system, start, (0.0, 0.1), 0.01, method=method)  # loaded or compiled
    geomint.solve_ensemble(system, X, (0.0, 0.1), 0.01, method=method, threads=2)
    before = rtsys.get_allocation_stats()
    for _ in range(5):
        geomint.solve(system, start, (0.0, 1.0), 0.01, method=method)
        geomint.solve_ensemble(system, X, (0.0, 1.0), 0.01, method=method, threads=2)
    after = rtsys.get_allocation_stats()
    print(after.alloc - before.alloc, (after.alloc - after.free) - (before.alloc - before.free))
"""


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="compiled code only")
def test_the_loop_borrows_its_arrays_and_frees_what_it_allocates():
    """The loop holds its arrays uncounted (``_kernels/borrow.py``): every allocation the compiled code makes
    (the loop's own buffer, once per call) is freed, none is leaked by a count taken and never dropped, in R^3 and
    in R^n.  Counted by numba's allocation statistics in a process of its own (switched on before numba loads)."""
    out = subprocess.run(
        [sys.executable, "-c", BORROWED],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "NUMBA_NRT_STATS": "1"},
    )
    assert out.returncode == 0, out.stderr
    for line in out.stdout.splitlines():
        allocated, kept = (int(n) for n in line.split())
        assert allocated >= 5 and kept == 0, out.stdout
