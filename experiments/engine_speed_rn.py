"""Per-step cost of the R^n engine against n: Newton, the fixed point and the automatic choice, against hand-written
exact steps of the same scheme as floors; and the LU factorisation by hand against LAPACK.

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python -m experiments.engine_speed_rn [--repeats R] [--processes P]
        [--floor-processes F]

Writes docs/engine_rn_speed.md.  As experiments/engine_speed.py: everything a table compares is measured in one
process, in interleaved repeats, reported as medians and as ratios within the run (the machine is shared:
absolute times move with the load, ratios much less); the ratios that decide the solver are measured again in
``--processes`` fresh processes and their median given.  Single-threaded (OPENBLAS_NUM_THREADS=1, set here before
numpy loads).

* the LU factorisation of a random n x n matrix: ``vecn.lu_factor`` (by hand) against ``vecn.lapack_factor``
  (LAPACK's dgetrf), n = 4 ... 256: where ``step_n.LAPACK_MIN_N`` comes from;
* per step, fixed steps h from a moving state, final state only: random Fish systems (n = 4, 16, 64), 2-D Euler
  (Zeitlin N = 5, 7, 33: n = 24, 48, 1088), the damped pendula (n = 17 ... 16385, L and M as actions, and as
  matrices up to n = 257), each with Newton forced, the fixed point forced (the workspace's ``WN_SOLVER``, a
  private switch: ``solve`` chooses by itself) and the automatic choice, with the iterations per step;
* the floor for the pendula: a hand-written exact step of the same system (``pendula_floor``), in the same run
  (its discrete gradient is the coordinate quotient ``(cos q' - cos q) / (q' - q)``, AVF's for the separable E with
  the integral exact, not Gonzalez's: a floor of the cost, not of the same scheme);
* against hand-written exact steps of the same scheme (``experiments/floors_rn.py``: Gonzalez's projected step, the
  field inlined, Newton to round-off, the library's acceptance) for the gas containers (n = 4), 2-D Euler (Zeitlin
  N = 5, n = 24), a random Fish system (n = 64) and the pendula (N = 128, n = 257): geomint (auto, Newton, fixed
  point) and the floor interleaved in each of ``--floor-processes`` fresh processes, the ratios per process and their
  median, the final states compared (the same scheme), each floor checked exact over its run, and the cost of one
  discrete field (geomint's, the floor's, the user's functions through first-class and static calls).

Those runs reach a private kernel (``geomint._kernels.loop.run``) on purpose: ``solve`` offers no switch to force
a solver, and these tables are what its automatic choice is calibrated against.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import multiprocessing  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from numba import njit  # noqa: E402

import geomint  # noqa: E402
from experiments.floors_rn import floor_for  # noqa: E402
from geomint import systems  # noqa: E402
from geomint._kernels import layout, loop, step_n  # noqa: E402
from geomint._kernels.vecn import LAPACK_INT, lapack_factor, lu_factor, matvec_into, remove_along  # noqa: E402
from geomint.run.chunks import new_output, new_run_state  # noqa: E402
from geomint.run.controller import constant_grid  # noqa: E402

DOCS = Path(__file__).resolve().parent.parent / "docs"
EPS = np.finfo(float).eps
SOLVERS = {"Newton": step_n.NEWTON_ONLY, "fixed point": step_n.FIXED_POINT_ONLY, "auto": step_n.AUTO}


# -- the LU factorisation ----------------------------------------------------------------------------------------
@njit(cache=True)
def _factor_many(a, copy, pivots_hand, pivots_lapack, lapack, times):
    for _ in range(times):
        a[:] = copy
        if lapack:
            lapack_factor(a, pivots_lapack)
        else:
            lu_factor(a.ravel(), 0, a.shape[0], pivots_hand, 0)


def lu_times(sizes, repeats):
    """Median ns per factorisation (the matrix copied in each time, as ``step_n.factor`` builds it)."""
    rows = {}
    for n in sizes:
        A = np.random.default_rng(n).normal(size=(n, n)) + n * np.eye(n)
        a, hand, lapack = np.empty((n, n)), np.zeros(n), np.zeros(n, dtype=LAPACK_INT)
        times = max(3, int(3e6 / n**2.6))
        samples = {True: [], False: []}
        for which in (True, False):
            _factor_many(a, A, hand, lapack, which, 2)
        for _ in range(repeats):
            for which in (True, False):
                start = time.perf_counter()
                _factor_many(a, A, hand, lapack, which, times)
                samples[which].append((time.perf_counter() - start) / times)
        rows[n] = (1e9 * statistics.median(samples[False]), 1e9 * statistics.median(samples[True]))
    return rows


# -- the floor: a hand-written exact step of the damped pendula -------------------------------------------------
@njit(cache=True)
def pendula_floor(x0, gamma, h, steps):
    """``steps`` exact steps of the damped pendula (``systems.damped_pendula``), written out: the discrete
    gradient of the separable E, ``(dE)_q = (cos q' - cos q) / (q' - q)``, ``(dE)_p = (p + p') / 2``, ``(dE)_s = 1``,
    and M built from its entries (``M grad E = 0`` holds for the discrete gradient with no projection,
    docs/engine_rn.md, "The discrete step")::

        q' = q + h pbar,   p' = p - h (dc + gamma pbar),   s' = s + h gamma |pbar|^2,

    each pendulum's 2 x 2 system by Newton to round-off (a step at the explicit start), then s' moved onto
    ``E = E(x0)`` (``dE/ds = 1``: the level correction made trivial).  A step is accepted only with E within
    4 ulps of its terms of E(x0) and s not falling; returns the final state and the steps that were not."""
    n = x0.shape[0]
    N = (n - 1) // 2
    x = x0.copy()
    E0 = x[n - 1]
    for i in range(N):
        E0 += 0.5 * x[N + i] * x[N + i] + np.cos(x[i])
    failed = 0
    for _ in range(steps):
        gain = 0.0
        for i in range(N):
            q, p = x[i], x[N + i]
            cq = np.cos(q)
            q1, p1 = q + h * p, p + h * (np.sin(q) - gamma * p)
            for _ in range(50):
                d = q1 - q
                if abs(d) > 1e-7 * (abs(q) + 1.0):
                    dc = (np.cos(q1) - cq) / d
                    ddc = (-np.sin(q1) - dc) / d
                else:
                    dc = -np.sin(0.5 * (q + q1))
                    ddc = -0.5 * np.cos(0.5 * (q + q1))
                pbar = 0.5 * (p + p1)
                r1 = q1 - q - h * pbar
                r2 = p1 - p + h * (dc + gamma * pbar)
                a11, a12 = 1.0, -0.5 * h
                a21, a22 = h * ddc, 1.0 + 0.5 * h * gamma
                det = a11 * a22 - a12 * a21
                c1 = (r1 * a22 - a12 * r2) / det
                c2 = (a11 * r2 - a21 * r1) / det
                q1 -= c1
                p1 -= c2
                if abs(c1) <= 2.0 * EPS * abs(q1) and abs(c2) <= 2.0 * EPS * (abs(p1) + abs(q1)):
                    break
            pbar = 0.5 * (p + p1)
            gain += gamma * pbar * pbar
            x[i], x[N + i] = q1, p1
        s = x[n - 1]
        rest, terms = 0.0, 0.0
        for i in range(N):
            e = 0.5 * x[N + i] * x[N + i] + np.cos(x[i])
            rest += e
            terms += abs(x[N + i] * x[N + i]) + abs(x[i] * np.sin(x[i]))
        s_new = s + h * gain
        if abs(rest + s_new - E0) > 4.0 * EPS * (max(abs(E0), terms) + abs(s_new)):
            s_new = E0 - rest
        E = rest + s_new
        if not (abs(E - E0) <= 4.0 * EPS * (max(abs(E0), terms) + abs(s_new)) and s_new >= s):
            failed += 1
        x[n - 1] = s_new
    return x, failed


# -- the engine with a forced solver ----------------------------------------------------------------------------
def engine_run(system, x0, h, steps, solver, every_state=False, method=None, inlined=False):
    """``steps`` fixed steps of the engine (Gonzalez) from ``x0`` with ``solver`` (``step_n.WN_SOLVER``), final
    state only: ``(state, counters, workspace)`` (``every_state``: the states of every step, (steps + 1, n), in
    place of the final one).  The user's functions first-class, as ``solve`` hands them to R^n kernels, or with
    ``inlined`` as it does under ``GEOMINT_INLINE=all`` (``geomint.model.handles.enabled``)."""
    data = (method or geomint.Gonzalez()).lower(system)
    t_end = steps * h
    grid, n_steps = constant_grid(0.0, t_end, h, 1 if every_state else None)
    out = new_output(n_steps + 1 if every_state else 4, len(x0))
    work, state = new_run_state(data, np.asarray(x0, dtype=float), True)
    work[step_n.WN_SOLVER] = solver
    clock = layout.new_clock(0.0)
    setting = os.environ.get("GEOMINT_INLINE")
    os.environ["GEOMINT_INLINE"] = "all" if inlined else "1"
    try:
        model, eps, ham = system.inlined_model, system.eps, system.hamiltonian  # as solve runs it
    finally:
        if setting is None:
            del os.environ["GEOMINT_INLINE"]
        else:
            os.environ["GEOMINT_INLINE"] = setting
    loop.run(model, eps, ham, data, grid, state, work, clock, np.array([t_end]), n_steps, out)
    if every_state:
        return out.x[: out.counters[layout.ROWS]].copy(), out.counters, work
    return state[: len(x0)], out.counters, work


def pendula_start(N):
    rng = np.random.default_rng(0)
    return np.concatenate([rng.uniform(-2.0, 2.0, N), rng.uniform(-1.0, 1.0, N), [0.0]])


def cases(quick=False):
    """(label, n, system, x0, h, steps, with floor): moving states, steps for ~0.05-0.3 s a run."""
    out = []
    for n in (4, 16, 64):
        x0 = np.random.default_rng(n).normal(size=n) * 0.5
        out.append(
            (f"random Fish, n = {n}", n, systems.random_fish(n, seed=1, eps=0.2), x0, 0.05, 40 if n == 64 else 200)
        )
    for N, steps in ((5, 200), (7, 100), (33, 6)):
        out.append(
            (
                f"Euler Zeitlin N = {N}",
                N * N - 1,
                systems.euler_zeitlin(N, eps=0.05),
                systems.euler_initial_state(N),
                0.05,
                steps,
            )
        )
    for N in (8, 32, 128, 512, 2048, 8192):
        n = 2 * N + 1
        out.append(
            (f"pendula N = {N}, actions", n, systems.damped_pendula(N), pendula_start(N), 0.1, max(4, 40000 // n))
        )
        if N <= 128:
            out.append(
                (
                    f"pendula N = {N}, matrices",
                    n,
                    systems.damped_pendula(N, form="matrix"),
                    pendula_start(N),
                    0.1,
                    max(4, 4000 // n),
                )
            )
    return out


def _solvers_for(n, label):
    allowed = dict(SOLVERS)
    if n > 1000:
        allowed.pop("Newton")  # no dense Jacobian (n > DENSE_MAX_N), or seconds per refresh (n + 1 fields, O(n^3))
    return allowed


def per_step(repeats):
    """Median ns per step of each (case, solver), the floor's for the pendula, the iterations per step and the
    solver the automatic choice ended in."""
    results = {}
    for label, n, system, x0, h, steps, *_ in cases():
        runs = {
            name: (lambda solver=solver: engine_run(system, x0, h, steps, solver))
            for name, solver in _solvers_for(n, label).items()
        }
        if label.startswith("pendula") and "actions" in label:
            runs["floor"] = lambda x0=x0, h=h, steps=steps: pendula_floor(x0, 0.5, h, steps)
        for run in runs.values():
            run()
        samples = {name: [] for name in runs}
        for _ in range(repeats):
            for name, run in runs.items():
                start = time.perf_counter()
                run()
                samples[name].append(time.perf_counter() - start)
        row = {}
        for name, run in runs.items():
            ns = 1e9 * statistics.median(samples[name]) / steps
            if name == "floor":
                _, failed = run()
                row[name] = (ns, None, f"{failed} steps not exact")
                continue
            _, counters, work = run()
            assert counters[layout.STATUS] == 0, (label, name, counters)
            iterations = counters[layout.NEWTON_ITERATIONS] / counters[layout.STEPS]
            mode = "fixed point" if work[step_n.WN_MODE] > 0.0 or n > step_n.DENSE_MAX_N else "Newton"
            row[name] = (
                ns,
                iterations,
                mode if name == "auto" else f"rate {work[step_n.WN_RATE]:.3f}" if name == "fixed point" else "",
            )
        results[label] = (n, row)
        print(label, {k: f"{v[0]:.0f}" for k, v in row.items()}, flush=True)
    return results


def crossover(repeats):
    """Newton against the fixed point as the rate grows with h: random Fish n = 16 (matrix), Euler N = 7 (matrix,
    O(n^2) field) and the pendula N = 32 (actions, n = 65): ns per step and iterations."""
    rows = []
    for label, system, x0, steps in (
        (
            "random Fish n = 16",
            systems.random_fish(16, seed=1, eps=0.2),
            np.random.default_rng(16).normal(size=16) * 0.5,
            100,
        ),
        ("Euler Zeitlin N = 7", systems.euler_zeitlin(7, eps=0.05), systems.euler_initial_state(7), 60),
        ("pendula N = 32, actions", systems.damped_pendula(32), pendula_start(32), 300),
    ):
        for h in (0.01, 0.05, 0.2, 0.5):
            runs = {
                name: (lambda solver=solver, h=h: engine_run(system, x0, h, steps, solver))
                for name, solver in SOLVERS.items()
                if name != "auto"
            }
            for run in runs.values():
                run()
            samples = {name: [] for name in runs}
            for _ in range(repeats):
                for name, run in runs.items():
                    start = time.perf_counter()
                    run()
                    samples[name].append(time.perf_counter() - start)
            entry = {"label": label, "h": h}
            for name, run in runs.items():
                _, counters, work = run()
                ok = counters[layout.STATUS] == 0
                entry[name] = (
                    1e9 * statistics.median(samples[name]) / steps if ok else np.nan,
                    counters[layout.NEWTON_ITERATIONS] / max(1, counters[layout.STEPS]),
                    work[step_n.WN_RATE],
                )
            _, counters, work = engine_run(system, x0, h, steps, step_n.AUTO)
            entry["auto"] = "fixed point" if work[step_n.WN_MODE] > 0.0 else "Newton"
            rows.append(entry)
            print(entry, flush=True)
    return rows


#: the ratios measured again in fresh processes: (label of a case of ``cases``)
SPREAD_CASES = ("random Fish, n = 16", "Euler Zeitlin N = 7", "pendula N = 128, actions")


def _ratios(repeats):
    """Fixed point / Newton and auto / the better of the two, for ``SPREAD_CASES``, in this process."""
    out = {}
    for label, _n, system, x0, h, steps in (c for c in cases() if c[0] in SPREAD_CASES):
        runs = {
            name: (lambda solver=solver: engine_run(system, x0, h, steps, solver)) for name, solver in SOLVERS.items()
        }
        for run in runs.values():
            run()
        samples = {name: [] for name in runs}
        for _ in range(repeats):
            for name, run in runs.items():
                start = time.perf_counter()
                run()
                samples[name].append(time.perf_counter() - start)
        t = {name: statistics.median(v) for name, v in samples.items()}
        out[label] = (t["fixed point"] / t["Newton"], t["auto"] / min(t["fixed point"], t["Newton"]))
    return out


def spread(repeats, processes):
    context = multiprocessing.get_context("spawn")
    samples = []
    for _ in range(processes):
        with context.Pool(1) as pool:
            samples.append(pool.apply(_ratios, (repeats,)))
    lines = [
        "",
        f"## The same ratios in {processes} fresh processes",
        "",
        "| case | fixed point / Newton, per process | median | auto / better forced, per process | median |",
        "|---|---|---|---|---|",
    ]
    for label in SPREAD_CASES:
        a = [sample[label][0] for sample in samples]
        b = [sample[label][1] for sample in samples]
        lines.append(
            f"| {label} | {', '.join(f'{r:.2f}' for r in a)} | {statistics.median(a):.2f} | "
            f"{', '.join(f'{r:.2f}' for r in b)} | {statistics.median(b):.2f} |"
        )
    return "\n".join(lines) + "\n"


# -- against hand-written exact steps of the same scheme (experiments/floors_rn.py) --------------------------------
#: the gas containers' start: the wall off centre and moving, the gases at different temperatures (relaxing by t ~ 40)
GAS_START = (0.6, 0.4, 0.2, -0.1)

#: the floors' cases: (label of a case of ``cases`` or the gas containers)
FLOOR_LABELS = ("gas containers", "Euler Zeitlin N = 5", "random Fish, n = 64", "pendula N = 128, actions")


def floor_cases():
    """(label, n, system, x0, h, steps) for the floors: the gas containers (n = 4, h = 0.05, 400 steps, t = 20,
    still moving) and the cases of ``cases`` at n = 24, 64, 257, at their h, start and steps."""
    known = {c[0]: c[:6] for c in cases()}
    gas = ("gas containers", 4, systems.gas_containers(), np.array(GAS_START), 0.05, 400)
    return [gas] + [known[label] for label in FLOOR_LABELS[1:]]


@njit
def _user_matrices(H, grad_H, S, grad_S, P, M, with_m, params, y, mid, v, out, times):
    """One iteration's calls of the user's functions as geomint's discrete field makes them (H and S at y, their
    gradients at the midpoint, P (and M) formed and applied to v), ``times`` times (y[0] stored again after each,
    from the total, so that nothing is hoisted out of the loop)."""
    total, y0 = 0.0, y[0]
    for _ in range(times):
        total += H(y, params) + S(y, params) + grad_H(mid, params)[0] + grad_S(mid, params)[0]
        matvec_into(out, P(mid, params), v)
        total += out[0]
        if with_m:
            matvec_into(out, M(mid, params), v)
            total += out[0]
        y[0] = y0 + 0.0 * total
    return total


@njit
def _user_actions(H, grad_H, S, grad_S, P_apply, M_apply, params, y, mid, v, times):
    """As ``_user_matrices`` with P and M given as actions."""
    total, y0 = 0.0, y[0]
    for _ in range(times):
        total += H(y, params) + S(y, params) + grad_H(mid, params)[0] + grad_S(mid, params)[0]
        total += P_apply(mid, v, params)[0] + M_apply(mid, v, params)[0]
        y[0] = y0 + 0.0 * total
    return total


@njit(cache=True)
def _geomint_field(data, model, eps, hamiltonian, x, y, H_x, S_x, work, times):
    """``times`` evaluations of geomint's discrete field (``step_n.discrete_field_n``) between x and y."""
    total, y0 = 0.0, y[0]
    for _ in range(times):
        H_y, S_y, noise, size_p, size_m = step_n.discrete_field_n(
            data.kind.code, data.coeffs, model, eps, hamiltonian, x, H_x, S_x, y, 0.0, 0.0, work, True
        )
        total += H_y + noise
        y[0] = y0 + 0.0 * total
    return total


@njit(cache=True)
def _projections(u, d, e, times):
    """The five projections of one evaluation of geomint's discrete field (``vecn.remove_along``: Pi_S before and
    after P, Pi_H before and after M, and the last along dgH), ``times`` times."""
    total = 0.0
    for _ in range(times):
        remove_along(u, d)
        remove_along(u, d)
        remove_along(u, e)
        remove_along(u, e)
        remove_along(u, e)
        total += u[0]
        u[0] = 1.0 + 0.0 * total
    return total


def _ns_per_call(calls, seconds=0.02, repeats=7):
    """ns per evaluation of each ``call(times)`` of ``calls`` (a dict), compiled loops: each call's ``times``
    doubled until a loop takes ``seconds`` (so that the call from Python, which unboxes the model, weighs nothing),
    then the calls interleaved ``repeats`` times, medians."""
    counts = {}
    for name, call in calls.items():
        call(2)
        times = 16
        while True:
            start = time.perf_counter()
            call(times)
            if time.perf_counter() - start >= seconds / 4:
                break
            times *= 2
        counts[name] = 4 * times
    samples = {name: [] for name in calls}
    for _ in range(repeats):
        for name, call in calls.items():
            start = time.perf_counter()
            call(counts[name])
            samples[name].append(time.perf_counter() - start)
    return {name: 1e9 * statistics.median(samples[name]) / counts[name] for name in calls}


def components(system, x, y, floor):
    """ns per evaluation, between x and y, interleaved: geomint's discrete field (through the model), its five
    projections, the floor's field, and the user's functions as one iteration calls them through the model's
    first-class functions and called directly (static calls of the same jitted functions)."""
    n = len(x)
    data = geomint.Gonzalez().lower(system)
    model, f = system.model, system.functions
    work = np.zeros(step_n.work_size(n))
    H_x, S_x = system.H(x), system.S(x)
    y, mid, v, out = y.copy(), 0.5 * (x + y), system.grad_H(0.5 * (x + y)), np.empty(n)
    p = model.params
    if system.actions:
        first = (model.H, model.grad_H, model.S, model.grad_S, model.P_apply, model.M_apply)
        static = (f.H, f.grad_H, f.S, f.grad_S, f.P_apply, f.M_apply)
        user = [lambda t, fns=fns: _user_actions(*fns, p, y, mid, v, t) for fns in (first, static)]
    else:
        with_m = f.M is not None
        first = (model.H, model.grad_H, model.S, model.grad_S, model.P, model.M)
        static = (f.H, f.grad_H, f.S, f.grad_S, f.P, f.M if with_m else f.P)
        user = [lambda t, fns=fns: _user_matrices(*fns, with_m, p, y, mid, v, out, t) for fns in (first, static)]
    directions = (np.asarray(system.grad_S(mid), dtype=float), np.asarray(system.grad_H(mid), dtype=float))
    eps, hamiltonian = system.eps, system.hamiltonian
    return _ns_per_call(
        {
            "geomint field": lambda t: _geomint_field(data, model, eps, hamiltonian, x, y, H_x, S_x, work, t),
            "projections": lambda t: _projections(np.ones(n), *directions, t),
            "floor field": lambda t: floor.fields(x, y, t),
            "user, first-class": user[0],
            "user, static": user[1],
        }
    )


def _against_floors(repeats):
    """In this process, for each of ``floor_cases``: geomint (auto, Newton, fixed point) and the floor from the same
    start at the same h, interleaved; ns per step (medians), iterations per step, the largest difference of the
    final states (floor against each geomint solver), the floor's exactness and the cost of one field."""
    out = {}
    for label, n, system, x0, h, steps in floor_cases():
        floor = floor_for(system)
        runs = {
            name: (lambda solver=solver: engine_run(system, x0, h, steps, solver)) for name, solver in SOLVERS.items()
        }
        runs["inlined"] = lambda: engine_run(system, x0, h, steps, step_n.AUTO, inlined=True)
        runs["floor"] = lambda: floor.run(x0, h, steps)
        for run in runs.values():
            run()
        samples = {name: [] for name in runs}
        for _ in range(repeats):
            for name, run in runs.items():
                start = time.perf_counter()
                run()
                samples[name].append(time.perf_counter() - start)
        row = {name: {"ns": 1e9 * statistics.median(v) / steps} for name, v in samples.items()}
        result = floor.run(x0, h, steps)
        apart = 0.0
        for name in (*SOLVERS, "inlined"):
            state, counters, work = runs[name]()
            assert counters[layout.STATUS] == 0, (label, name, counters)
            row[name]["its"] = counters[layout.NEWTON_ITERATIONS] / counters[layout.STEPS]
            row[name]["mode"] = "fixed point" if work[step_n.WN_MODE] > 0.0 else "Newton"
            apart = max(apart, float(np.max(np.abs(state - result.x))))
        row["floor"].update(its=result.iterations / steps, run=result._replace(x=None), apart=apart)
        y = floor.run(x0, h, 1).x
        row["components"] = components(system, np.asarray(x0, dtype=float), y, floor)
        out[label] = (n, steps, row)
    return out


def against_floors(repeats, processes):
    """``_against_floors`` in ``processes`` fresh processes: the tables of the section "Against hand-written exact
    steps"."""
    context = multiprocessing.get_context("spawn")
    samples = []
    for _ in range(processes):
        with context.Pool(1) as pool:
            samples.append(pool.apply(_against_floors, (repeats,)))
        print(
            "floors",
            {k: {m: f"{v[2][m]['ns']:.0f}" for m in ("auto", "inlined", "floor")} for k, v in samples[-1].items()},
        )
    return samples


def roots():
    """For each of ``floor_cases``, in this process: the largest residual of the scheme at an accepted step over the
    benchmark run (``Floor.residual_ulps``: ``|(x' - x) - h F(x, x')|_inf`` in ulps of ``|x'|_inf``, F the floor's
    field) for geomint's three solvers and the floor: how close each stops to the step's root."""
    out = {}
    for label, n, system, x0, h, steps in floor_cases():
        floor = floor_for(system)
        every = {name: engine_run(system, x0, h, steps, solver, True)[0] for name, solver in SOLVERS.items()}
        # the floor's state after k steps is the k-th of its run's (runs are deterministic)
        every["floor"] = np.array([x0] + [floor.run(x0, h, k).x for k in range(1, steps + 1)], dtype=float)
        row = {}
        for name, states in every.items():
            assert states.shape == (steps + 1, n), (label, name, states.shape)
            row[name] = max(floor.residual_ulps(x0, a, b, h) for a, b in zip(states[:-1], states[1:], strict=True))
        out[label] = (n, row)
        print("roots", label, {k: f"{v:.1f}" for k, v in row.items()}, flush=True)
    return out


def gap_table(samples):
    """The ratio auto / floor split into factors, per system: iterations per step (geomint / floor), one discrete
    field (geomint / floor), and the rest of a step (what a step costs beyond its fields, relative: the ratio
    divided by the other two, so that the three multiply to it); and geomint's field split into the user's
    functions (through the model), the first-class calls' share of them, its five projections and the rest of
    its own code, in ns and as shares of the field."""

    def med(values):
        return statistics.median(list(values))

    lines = [
        "",
        "## What the gap is made of",
        "",
        "auto / floor (the median above) = iterations per step (geomint / floor) × one discrete field "
        "(geomint / floor) × the rest of a step (Jacobians, solves, predictor, corrections, the loop: the ratio "
        "divided by the other two). Then geomint's discrete field, in ns: the user's functions as one iteration "
        "calls them (through the model's first-class functions; the first-class calls' own cost, the difference "
        "with static calls, in brackets), its five projections, and the rest of its own code (discrete gradients "
        "in general form, the sizes of P and M for the quotients' switching rule, copies into its workspace).",
        "",
        "| n | system | auto / floor | = iterations | × one field | × rest of the step | geomint field | "
        "user functions (first-class cost) | projections | the rest of geomint's field | floor field |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, (n, _steps, row) in samples[0].items():
        rows = [sample[label][2] for sample in samples]
        ratio = med(r["auto"]["ns"] / r["floor"]["ns"] for r in rows)
        iterations = row["auto"]["its"] / row["floor"]["its"]
        comp = {key: med(r["components"][key] for r in rows) for key in rows[0]["components"]}
        field = med(r["components"]["geomint field"] / r["components"]["floor field"] for r in rows)
        user, projections = comp["user, first-class"], comp["projections"]
        rest = comp["geomint field"] - user - projections
        lines.append(
            f"| {n} | {label} | {ratio:.1f} | {iterations:.2f} | {field:.2f} | {ratio / (iterations * field):.2f} | "
            f"{comp['geomint field']:,.0f} | {user:,.0f} ({user - comp['user, static']:+,.0f}) | {projections:,.0f} | "
            f"{max(rest, 0.0):,.0f} | {comp['floor field']:,.0f} |"
        )
    return "\n".join(lines) + "\n"


def floors_report(samples, repeats, residuals):
    def med(label, name, key="ns"):
        return statistics.median(sample[label][2][name][key] for sample in samples)

    def ratios(label, name):
        values = [sample[label][2][name]["ns"] / sample[label][2]["floor"]["ns"] for sample in samples]
        return ", ".join(f"{r:.1f}" for r in values), statistics.median(values)

    first = samples[0]
    lines = [
        "",
        "## Against hand-written exact steps",
        "",
        "`experiments/floors_rn.py`: for each system a hand-written numba step of the scheme geomint's `Gonzalez()` "
        "takes (the projected step with Gonzalez's discrete gradients, H's anchored to H(x₀) as the library's), the "
        "field typed out for the system and applied as actions from the formulas' zero pattern (no first-class "
        "function, no array returned by a user function; the random Fish system's K = A + Σ xₖBₖ formed over its "
        "upper triangle, A and Bₖ being skew; Zeitlin's P from index tables built once), solved by simplified "
        "Newton to round-off with A = I − (h/2)Dξ: Dξ by differences of the inlined field, kept while the first "
        "contraction rate stays below 0.1 (2-D Euler; the random Fish system, whose columns cost O(n²) each, K "
        "being affine in x), or fresh at every step where it costs about an iteration or less (the gas containers "
        "by differences, n = 4; the pendula by hand from the zero pattern, each pendulum's 2 × 2 block and the s "
        "row, O(n)); H moved back onto H(x₀) along Π_S∇H where it is more than an ulp of its terms off (the "
        "library's level correction), and each step checked by the library's acceptance (H within 4 ulps of its "
        "terms of H(x₀), S not against its direction by more than 2 ulps). Same start, same h, in the same "
        f"process as geomint's runs, interleaved ({repeats} repeats, medians), in {len(samples)} fresh processes; "
        "ns per step the median over the processes. Iterations per step in brackets (geomint: the solver the "
        "automatic choice ended in). geomint auto: the user's functions first-class, as `solve` hands them to "
        "R^n kernels by default; inlined: the same run with them inlined into kernels compiled for the system, "
        "as under `GEOMINT_INLINE=all` (a new system's first solve then compiles for about a minute: "
        "[start-up](startup.md)).",
        "",
        "| n | system | steps | geomint auto ns/step | floor ns/step | auto / floor, per process | median | "
        "inlined ns/step | inlined / floor, per process | median | final states apart |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, (n, steps, row) in first.items():
        per, median = ratios(label, "auto")
        per_inlined, median_inlined = ratios(label, "inlined")
        apart = max(sample[label][2]["floor"]["apart"] for sample in samples)
        lines.append(
            f"| {n} | {label} | {steps} | {med(label, 'auto'):,.0f} ({row['auto']['its']:.1f}, {row['auto']['mode']}) "
            f"| {med(label, 'floor'):,.0f} ({row['floor']['its']:.1f}) | {per} | **{median:.1f}** | "
            f"{med(label, 'inlined'):,.0f} | {per_inlined} | **{median_inlined:.1f}** | {apart:.1e} |"
        )
    lines += [
        "",
        "Final states apart: the largest |x_floor − x_geomint| over the four geomint runs and the "
        "processes, at the end of the run: both solve the same scheme, apart by where each solver stops (the "
        "residuals below).",
        "",
        "With the solver forced (the script's `WN_SOLVER`), against the same floor:",
        "",
        "| n | system | Newton ns/step (its) | Newton / floor, per process | median | fixed point ns/step (its) | "
        "fixed point / floor, per process | median |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label, (n, _steps, row) in first.items():
        newton, newton_median = ratios(label, "Newton")
        fixed, fixed_median = ratios(label, "fixed point")
        lines.append(
            f"| {n} | {label} | {med(label, 'Newton'):,.0f} ({row['Newton']['its']:.1f}) | {newton} | "
            f"{newton_median:.1f} | {med(label, 'fixed point'):,.0f} ({row['fixed point']['its']:.1f}) | {fixed} | "
            f"{fixed_median:.1f} |"
        )
    lines += [
        "",
        "**The floors are exact** (checked over each benchmark run, in every process; the runs are deterministic, "
        "so every process gives the same figures): steps failing the acceptance or not converging, the largest "
        "|H − H(x₀)| and the largest move of S against its direction, in ulps of their terms (≤ 0: S never moved "
        "against it), the level moves of H, the Jacobians formed.",
        "",
        r"| n | system | steps failing | max \|ΔH\| (ulps of terms) | max S against direction (ulps) | "
        "level moves | Jacobians |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, (n, steps, _row) in first.items():
        runs = [sample[label][2]["floor"]["run"] for sample in samples]
        run = runs[0]
        failing = max(r.failures for r in runs)
        lines.append(
            f"| {n} | {label} | {failing} of {steps} | {max(r.worst_H for r in runs):.2f} | "
            f"{max(0.0, max(r.worst_S for r in runs)):.2f} | {run.moves} | {run.refreshes} |"
        )
    lines += [
        "",
        "**How close each solver stops to the step's root**: the largest residual of the scheme at an accepted "
        "step over the run, |x′ − x − h F(x, x′)|∞ in ulps of |x′|∞, F the floor's discrete field (measured in this "
        "script's own process; a state saved at every step). The floor's column is this measure's own noise (F "
        "evaluated in floating point, Gonzalez's quotients, the level move after the solve): compare across a row.",
        "",
        "| n | system | geomint auto | Newton | fixed point | floor |",
        "|---|---|---|---|---|---|",
    ]
    for label, (n, row) in residuals.items():
        lines.append(
            f"| {n} | {label} | {row['auto']:,.0f} | {row['Newton']:,.0f} | {row['fixed point']:,.0f} | "
            f"{row['floor']:,.0f} |"
        )
    return "\n".join(lines) + "\n"


def report(lu, steps, cross, repeats):
    lines = [
        "# Solving the step in Rⁿ: speed",
        "",
        "Regenerate: `OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python -m experiments.engine_speed_rn`. Medians of "
        f"{repeats} interleaved repeats in one process, single thread, on a shared 2-core machine: compare "
        "within a table, not across pages. Fixed steps from a moving state, the final state only.",
        "",
        "## The LU factorisation: by hand or by LAPACK",
        "",
        "| n | by hand (µs) | LAPACK dgetrf (µs) | hand / LAPACK |",
        "|---|---|---|---|",
    ]
    for n, (hand, lapack) in lu.items():
        lines.append(f"| {n} | {hand / 1e3:.2f} | {lapack / 1e3:.2f} | {hand / lapack:.2f} |")
    lines += [
        "",
        f"`step_n.LAPACK_MIN_N = {step_n.LAPACK_MIN_N}`: the factors by LAPACK from there on. The solve with the "
        "factors is written out in both cases (O(n²), as dgetrs would for one right-hand side).",
        "",
        "## ns per step against n",
        "",
        "Newton and the fixed point forced, and the automatic choice (`choose_solver`, the solver it ended in); "
        "iterations per step in brackets (the fixed point's mean contraction rate after them). The floor, for "
        "the pendula: `pendula_floor`, a hand-written exact step of the same system (each pendulum's 2 × 2 system "
        "by Newton to round-off, s moved onto E = E₀, accepted only with E within 4 ulps and s not falling), "
        "checked exact at every step. Its discrete gradient is the coordinate quotient (cos q′ − cos q)/(q′ − q) "
        "(AVF's for the separable E, the integral exact), not Gonzalez's, which couples the pendula through its "
        'correction: a floor of the cost, not of the same scheme; the section "Against hand-written exact steps" '
        "compares geomint with floors of its own scheme.",
        "",
        "| system | n | Newton | fixed point | auto | auto / best forced | floor | auto / floor |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label, (n, row) in steps.items():

        def cell(name):
            if name not in row:
                return "—"
            ns, its, note = row[name]
            return f"{ns:,.0f} ({its:.1f}{', ' + note if note else ''})"

        forced = [row[name][0] for name in ("Newton", "fixed point") if name in row]
        auto = row["auto"][0]
        floor = row.get("floor")
        lines.append(
            f"| {label} | {n} | {cell('Newton')} | {cell('fixed point')} | {auto:,.0f} ({row['auto'][1]:.1f}, "
            f"{row['auto'][2]}) | {auto / min(forced):.2f} | "
            + (f"{floor[0]:,.0f} ({floor[2]}) | {auto / floor[0]:.1f} |" if floor else "— | — |")
        )
    wins = {"Newton": [], "fixed point": []}
    for label, (n, row) in steps.items():
        if "Newton" in row:
            better = "Newton" if row["Newton"][0] <= row["fixed point"][0] else "fixed point"
            ratio = row["fixed point"][0] / row["Newton"][0]
            wins[better].append(f"{label} (n = {n}, fixed point / Newton {ratio:.2f})")
    lines += [
        "",
        "Where each forced solver wins: Newton on "
        + "; ".join(wins["Newton"])
        + ". The fixed point on "
        + "; ".join(wins["fixed point"])
        + ". Beyond n = 1000 only the fixed point is timed (a refresh costs "
        "n + 1 field evaluations and O(n³); above n = 2048 the workspace holds no Jacobian).",
    ]
    lines += [
        "",
        "## Where each solver wins: the crossover as the rate grows with h",
        "",
        "| system | h | Newton ns (its) | fixed point ns (its, rate) | fixed point / Newton | auto chose |",
        "|---|---|---|---|---|---|",
    ]
    for entry in cross:
        newton, fixed = entry["Newton"], entry["fixed point"]
        lines.append(
            f"| {entry['label']} | {entry['h']} | {newton[0]:,.0f} ({newton[1]:.1f}) | {fixed[0]:,.0f} "
            f"({fixed[1]:.1f}, {fixed[2]:.3f}) | {fixed[0] / newton[0]:.2f} | {entry['auto']} |"
        )
    return "\n".join(lines) + "\n"


FLOORS_READING = """
Reading these tables (the run this page was written from):

- **Each floor is a floor**: exact at every step of its run (no step failing, |ΔH| within 2.4 ulps of its terms, S
  never against its direction), on geomint's trajectory (final states within 3·10⁻¹¹) and as close to the step's
  root as geomint's solvers within that measure's noise. This page was regenerated on 2026-11-27, after the
  rest of the Rⁿ step's small kernels were handed to LLVM to inline (`jit.hot`: `vecn`'s matrix-vector product,
  row norm and LU factor and solve; the field, its dissipative part and its Jacobian by differences; the
  Newton matrix's refresh, factors and solve). Systems in Rⁿ hand their functions to the step loop
  first-class by default (docs/startup.md, "Rⁿ systems first-class": a new system's first solve 3 s instead
  of about a minute): the auto columns are that run, the inlined column the same run under
  `GEOMINT_INLINE=all`. The gas containers: 2.2 × first-class (2.4 the day before, with only the discrete
  field's helpers inlined; the same script, interleaved with the commit before in fresh processes: 2.07–2.17
  against 2.46–2.56), 1.8 × inlined; from n = 24 on the two columns are within 0.1 of each other. perf on the
  gas containers' run before this change: 12 % of the samples in `malloc`, `free` and numba's allocator and
  reference counts (the arrays the user's functions return: grad E, grad S, L and M at every field, four at
  each of the refresh's five evaluations of ξ, about 40 a step; the floor allocates none, and inlining the
  user's functions does not remove them), 13 % in `exp` and `log` (the user's E, grad E and M each take
  the two internal energies again, where the floor takes them once per point), 22 % in the small kernels
  inlined now (their work and their calls). What is left at n = 4, first-class, is the field
  (562 ns against the floor's 235: the user's four functions 246 of it, their first-class calls 101; the
  projections 81) and the refresh's five evaluations of ξ through the user's matrix functions; the
  iterations match the floor's (3.9 against 3.7). The price: the first-class Rⁿ kernels compile once per
  machine (an empty cache: the gas containers' first solve) in 121 s where they took 95 s. Earlier in the
  history of these ratios: before the step loop stopped counting references to its arrays
  (docs/engine_speed.md, reading) they were 4.5, 5.5, 7.3 and 4.6; before the catalogue's Euler and random
  Fish P were written at the cost of their structure (below), 1.9, 3.2, 6.7 and 4.2; the pendula were at
  3.7–4.5 × until the session before; the gas containers at 3.2 until their Newton took a fresh Jacobian at
  every step (docs/engine_rn.md).
  The figures in the bullets below are from earlier runs where they differ from the tables above.
- **The pendula at the floor's iterations (3.7 a step).** The floor forms the pendula's Newton matrix from the
  zero pattern of L and M at every step (each pendulum's 2 × 2 block and the s row, O(n)). geomint now probes
  that pattern once a run (`sparse_n`, docs/engine_rn.md "Solving the step": n + 1 evaluations of ξ, ~0.45 ms
  at n = 257, ~3 µs a step of this 155-step run), finds 129 blocks in 2 colours and the entropy's row bordered,
  and takes a fresh block Jacobian at every step (3 evaluations of ξ) with the linearly implicit start: 3.7
  Newton iterations a step (3.8 in the automatic choice, which tries the fixed point now and then), where it
  took 9.6 fixed-point iterations (Newton, forced, with its dense Jacobian: 14 × the floor). Three changes made
  the iterations match: the entropy's row solved by one directional difference a solve (left out of the
  matrix, s trails the others by an iteration: 5.4 iterations), the first iterate's field with Gonzalez's
  correction (the last step's gains: 5.05 → 3.7 with a dense fresh Jacobian), and the fresh Jacobian at
  every step (kept while it contracts: 5.3). The rest of the gap is the field (×1.25: geomint's 5.3 µs, of
  which the user's functions 2.6, against the floor's 4.3) and the rest of the step (×1.5: the directional
  difference, ~1.5 µs a solve; the refresh, ~6 µs; the probe; the level corrections). The pattern pays after
  about n/5 steps: at n = 1025 the 39-step run of the table above pays a probe of ~6 ms for ~4 Newton
  iterations a step and costs 1.5 × the fixed point; a long run gains.
- **The discrete field in fewer passes** (this session): its dot products and maxima in four partial chains,
  the projections' sums in shared passes, the Gonzalez correction and the scalings by a reciprocal: 9.5 → 5.3
  µs a field on the pendula (of which the user's functions 2.6).
- **The solver choice's cost model.** It counts field evaluations, a field modelled as 1000 + 4n² flops (matrices)
  or 1000 + 100n (actions); the fixed 1000, added in this run, is the field's own work around the user's
  functions (the last column but one below: ~1.1 µs at n = 4 and 24). Without it a Newton iteration at n = 4 was
  priced at 1.5 fields where it costs barely more than one, and the gas containers stayed in the fixed point (9.5
  iterations, 2.05 × the floor) where Newton (7.0) costs 1.8. Newton's refreshes are assumed at one per probe
  interval of 8 steps until measured (was SUNDIALS' one per 20): on the random Fish system, after a first
  fixed-point try of 14–18 iterations, a Newton step priced at 0.05 refreshes (65 evaluations of an O(n³) field
  each) looked cheaper and took the next 8 steps at ~0.3 refreshes each (2.02 × the floor); now it keeps the
  fixed point (1.55).
- **User functions that form dense matrices.** The catalogue's Euler P was formed as a 24 × 24 matrix at every
  call with each entry through modular index lookups (5.2 of geomint's 6.5 µs a field), and the random Fish P
  added each of its 64 `x_k B_k` through an allocated n × n temporary (198 of 201 µs). Both now form the same
  matrices, bit for bit, at the cost of their structure, as the floors apply them: Euler's from index tables
  built once with the system (in its `params`, `systems.euler._tables`), the random Fish K over its upper
  triangle without temporaries (A and Bₖ are skew), each row's segment a contiguous loop. A field now costs 2.1
  µs on Euler (its user functions 0.8) against the floor's 0.9, and 66 µs on the random Fish system (its
  user functions 62) against 54: the gap left there is geomint's, not the user's.
- **First-class calls: not a measurable part.** Called statically, the same functions save 39 ns an iteration
  at n = 4 (of 201), 32 on Euler (of 5,158), 49 on the pendula (of 1,520) and 1.5 µs on the random Fish system
  (of 198 µs, within its noise).
- **Allocation by user functions returning arrays** is inside the user-function column: on the pendula the six
  calls (H, S, and four returning a new array of 257: the gradients, L v, M v) cost 1.5 µs a field, not where
  that gap is; on Euler and the random Fish system the allocated matrices are part of the forming above.
- **geomint's own code around the user's functions.** The rest of its field is 0.95 µs at n = 4 (where the
  floor's whole field takes 0.32 µs), 1.1 µs on Euler and 3.9 µs on the pendula; its five projections, general
  (each a scaled pass over n), add 3.4 µs on the pendula, where the floor knows that Π_S zeroes the s entry and
  projects twice. Together: the pendula's field ×2.5 the floor's, the gas containers' ×3.9.
- **The rest of the step** weighs more in the floor's step where it forms a Jacobian at every step (factor 0.45
  on the gas containers, 0.7 on the pendula), and in geomint's on the random Fish system (×1.4): its automatic
  choice starts with Newton, whose Jacobian costs n + 1 = 65 evaluations of a field of O(n³).
- **geomint's fixed point stops short of the root on the pendula**: residuals up to 3·10⁴ ulps of |x′| (in s),
  where its Newton ends at 4, as the floor, apparently where its iteration accepts a correction that has
  stopped shrinking below √eps |x| (`step_n._iterate`; not separated here). H and S stay exact (its level
  corrections), but the step is not the scheme's root to round-off: its final state is 3·10⁻¹¹ from the floor's.
"""


READING = """
## Reading the tables (the run this page was written from)

- **Pendula as actions: the cost per step is linear in n.** Up to n = 2048 by Newton on the Jacobian's zero
  pattern (3.7 iterations, 1.7–2.1 × the hand-written floor `pendula_floor`, which is exact at every step too;
  at n = 1025 the probe outweighs a 39-step run), above by the fixed point (9.7 → 11.8 iterations from n = 4097
  to n = 16385: the mean rate stays ≈ 0.05 = (h/2)|Dξ|; ~3 × the floor). Given as matrices the same system
  pays O(n²) per iteration (×13 at n = 257), and Newton O(n³) per refresh (×3 the fixed point at n = 257).
- **Newton wins** where a field evaluation costs about as much as the solve (matrices) and the fixed point
  needs more iterations: Euler at n = 48 (fixed point / Newton 1.04; at n = 24 the fixed point, 0.91, since
  its P costs O(n²) from tables), 1.1 at h = 0.2, the pendula as matrices at n = 17 (1.5), random Fish at n = 4
  (1.1) and wherever (h/2)|Dξ| grows past ≈ 0.1 (the crossover tables: 1.1–1.5 from rates 0.1–0.2 on).
- **The fixed point wins** where the solve costs more than the field (actions: 0.33 at n = 257, 0.66 at
  n = 17), where refreshes are frequent and the field dear (random Fish, whose P costs O(n³) per
  evaluation: 0.32 at n = 64), and at small rates (≤ 0.03: 0.4–0.7).
- **The automatic choice** lands within 13 % of the better forced solver (random Fish at n = 16: 1.13; in the
  crossover table random Fish at h = 0.2, where it keeps the fixed point at 1.13 × Newton): its cost model
  prices a matrix field at 1000 + 4n² flops, and random Fish's costs O(n³), so the solve is overpriced there.
  Euler at n = 1088 runs by the fixed point alone (a Newton refresh: 1089 fields and an O(n³) factorisation).
- **LAPACK** factors faster than the hand-written elimination from n = 24 (×4–10 from n = 32); below, the
  call costs more than the work.
"""


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--processes", type=int, default=3, help="fresh processes for the spread of the ratios")
    parser.add_argument(
        "--floor-processes", type=int, default=5, help="fresh processes for the comparison with the floors"
    )
    args = parser.parse_args(argv)
    started = time.perf_counter()
    lu = lu_times((4, 8, 16, 24, 32, 48, 64, 128, 256), args.repeats)
    print("lu", lu, flush=True)
    steps = per_step(args.repeats)
    cross = crossover(args.repeats)
    text = report(lu, steps, cross, args.repeats)
    text += spread(args.repeats, args.processes)
    residuals = roots()
    samples = against_floors(args.repeats, args.floor_processes)
    text += floors_report(samples, args.repeats, residuals)
    text += gap_table(samples)
    text += FLOORS_READING
    text += READING
    text += f"\nThe whole script took {time.perf_counter() - started:.0f} s.\n"
    (DOCS / "engine_rn_speed.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
