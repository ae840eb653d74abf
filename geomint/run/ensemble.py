"""Ensembles and sweeps: many trajectories in one compiled call, on every core, or on a Dask cluster.

``solve_ensemble`` integrates ``n`` starts (each with its own parameters and
eps, if given) with one compiled batch kernel over numba's parallel range
(``geomint._kernels.batch``, run by one thread per core; it releases the GIL):
no Python per trajectory or per step.  Each
trajectory runs exactly the step loop of ``geomint.solve``, so trajectory
``i`` is bit for bit ``solve(system, X0[i], ...)``.  A failure stops only its
own trajectory; its rows up to the failure are kept, the rest padded with NaN
(``rows`` says how many are valid), and its status and message are kept.

Steps are fixed (``h``) or adaptive (``h=None`` with ``rtol``/``atol``, as in
``solve``); adaptive runs keep the states at ``t_eval`` (default: the start and
the end), so every trajectory has the same rows.

``backend="dask"`` ships chunks of trajectories to a ``dask.distributed``
client (``pip install geomint[dask]``); each worker runs the same batch
kernel, so the arrays equal the local ones bit for bit, and a worker lost
mid-run has its chunks run again by Dask.

``sweep`` runs a grid of eps values and parameter sets over the same starts.

Systems in R^n (``MetriplecticSystemN``, ``GenericSystem``) run the same way:
starts of shape (m, n), states of shape (m, rows, n), the batch kernel building
each trajectory's ``layout.ModelN``.  What ``solve`` does not offer in R^n yet
(``solve.check_in_rn``: the R^3 exact flows, the symmetric projection) is
refused here with the same message.
"""

from __future__ import annotations

import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numba
import numpy as np

from .. import _user_errors, _validate
from .._kernels import batch as _batch
from .._kernels import layout as _layout
from ..model.system import MetriplecticSystem
from ..model.system_n import MetriplecticSystemN
from ..results import io as _io
from ..results.solution import AccuracyWarning, Solution
from .arguments import check_direction, check_memory, check_span, check_states, check_t_eval
from .chunks import interrupts, workspace_size
from .controller import RTOL, check_step_or_control, constant_grid, landing_control
from .solve import (
    check_in_rn,
    choose_method,
    raised_message,
    run_message,
    step_caveat,
    step_ratios,
    tolerance_caveat,
)
from .status import Status

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable

    import numpy.typing as npt
    import xarray

    from .._kernels import control as _control
    from ..integrators import Integrator

#: trajectories per call of the batch kernel (between calls: progress, Ctrl-C, Dask tasks)
CHUNK = 256
#: fixed steps: the step's ratio to the dynamics (``solve.step_ratios``) is checked for at most this many distinct
#: (eps, params) of a sweep (the first ones); the trajectories of the others get NaN
RATIO_GROUPS = 256


@dataclass(frozen=True)
class Ensemble:
    """``n`` trajectories of one system and method, stacked.

    Attributes
    ----------
    t : (n, rows) array
        Saved times of each trajectory; NaN after its ``rows[i]`` valid rows.
    x : (n, rows, dim) array
        States at ``t`` (NaN-padded likewise); ``dim`` is 3, or the dimension of
        a system in R^n.
    H, S : (n, rows) arrays
        Energy and Casimir at ``t``.
    rows : (n,) int array
        Valid rows of each trajectory.
    status : (n,) int array
        The ``geomint.Status`` code of each trajectory (``Solution.status``), and
        -5 ``INVALID_START``: the start was refused (not finite, or H or S not
        finite there), 3 ``NOT_RUN``: not run (Ctrl-C).
    failed_step : (n,) int array
        The failed step, 0 where none failed.
    messages : tuple of str
        What happened to each trajectory.
    n_steps, n_newton, nfev, n_rejected : (n,) int arrays
        Work per trajectory (rejected: attempted adaptive steps not kept).
    eps : (n,) array
        eps of each trajectory.
    params : (n, p) array
        Parameters of each trajectory.
    method : Integrator
    caveats : tuple of tuples of str
        Per trajectory, as ``Solution.caveats`` (each sentence also ends its
        message; one ``AccuracyWarning`` for the ensemble).  Empty when none.
    step_ratio : (n,) array or None
        Fixed steps: ``|h|`` times each trajectory's local rate, as
        ``Solution.step_ratio`` (NaN where unknown).  None for adaptive steps.
    variables : tuple of str
        The names of the coordinates (the system's ``variables``; ``("x", "y", "z")`` in R^3).
    S_direction : float
        The direction of S of the system, as ``Solution.S_direction``: -1.0 where S
        never rises (Fish form), +1.0 where it never falls (GENERIC's entropy).
    """

    t: np.ndarray
    x: np.ndarray
    H: np.ndarray
    S: np.ndarray
    rows: np.ndarray
    status: np.ndarray
    failed_step: np.ndarray
    messages: tuple
    n_steps: np.ndarray
    n_newton: np.ndarray
    nfev: np.ndarray
    n_rejected: np.ndarray
    eps: np.ndarray
    params: np.ndarray
    method: Integrator
    caveats: tuple = ()
    step_ratio: np.ndarray | None = None
    variables: tuple = ("x", "y", "z")
    S_direction: float = -1.0

    def __len__(self) -> int:
        return len(self.status)

    @property
    def success(self) -> npt.NDArray[np.bool_]:
        """True where the trajectory reached ``t_end``, shape (n,)."""
        return self.status == 0

    @property
    def x_final(self) -> npt.NDArray[np.float64]:
        """The last state each trajectory reached, shape (n, dim) (its start if it was not run)."""
        return self.x[np.arange(len(self)), np.maximum(self.rows - 1, 0)]

    def solution(self, i: int) -> Solution:
        """Trajectory ``i`` as a ``geomint.Solution``."""
        n = int(self.rows[i])
        status = Status(int(self.status[i]))
        return Solution(
            t=self.t[i, :n].copy(),
            x=self.x[i, :n].copy(),
            H=self.H[i, :n].copy(),
            S=self.S[i, :n].copy(),
            success=status == 0,
            status=status,
            message=self.messages[i],
            failed_step=int(self.failed_step[i]) or None,
            n_steps=int(self.n_steps[i]),
            n_newton=int(self.n_newton[i]),
            nfev=int(self.nfev[i]),
            method=self.method,
            n_rejected=int(self.n_rejected[i]),
            caveats=self.caveats[i] if self.caveats else (),
            step_ratio=None if self.step_ratio is None else float(self.step_ratio[i]),
            S_direction=self.S_direction,
        )

    def to_xarray(self, param_names: Iterable[str] | None = None) -> xarray.Dataset:
        """An ``xarray.Dataset`` (optional dependency: ``pip install geomint[xarray]``).

        Dimensions ``trajectory``, ``time`` (the saved rows; ``t`` is a
        coordinate per trajectory) and ``component``, labelled with the
        system's ``variables``; eps, the parameters (named by ``param_names`` if
        given), status and rows are coordinates of ``trajectory``.  The
        attributes say what S is (``S_direction``, ``S_meaning``), as
        ``Solution.to_xarray``'s do.
        """
        try:
            import xarray as xr
        except ImportError:
            raise ImportError("Ensemble.to_xarray needs xarray: pip install geomint[xarray]") from None
        names = list(param_names) if param_names is not None else [f"p{k}" for k in range(self.params.shape[1])]
        if len(names) != self.params.shape[1]:
            raise ValueError(f"`param_names` must name {self.params.shape[1]} parameters; got {names!r}.")
        coords = {
            "component": list(self.variables),
            "eps": ("trajectory", self.eps),
            "status": ("trajectory", self.status),
            "rows": ("trajectory", self.rows),
            "t": (("trajectory", "time"), self.t),
        }
        coords.update({name: ("trajectory", self.params[:, k]) for k, name in enumerate(names)})
        data = xr.Dataset(
            {
                "x": (("trajectory", "time", "component"), self.x),
                "H": (("trajectory", "time"), self.H),
                "S": (("trajectory", "time"), self.S),
            },
            coords=coords,
            attrs=_io.direction_attrs(self.S_direction),
        )
        data["S"].attrs.update(_io.S_attrs(self.S_direction))
        return data


def solve_ensemble(
    system: MetriplecticSystem,
    X0: npt.ArrayLike,
    t_span: tuple[float, float],
    h: float | None = None,
    method: Integrator | str | None = None,
    *,
    rtol: float | None = None,
    atol: float | None = None,
    first_step: float | None = None,
    max_step: float | None = None,
    t_eval: npt.ArrayLike | None = None,
    params: npt.ArrayLike | None = None,
    eps: npt.ArrayLike | None = None,
    save_every: int | None = 1,
    progress: Callable[[int], object] | None = None,
    backend: str = "local",
    client: Any = None,
    chunk: int = CHUNK,
    threads: int | None = None,
) -> Ensemble:
    """Integrate every start ``X0[i]`` in one compiled batch kernel over all cores.

    Parameters
    ----------
    system : MetriplecticSystem
        In R^3, or in R^n (``MetriplecticSystemN``, ``GenericSystem``): fixed
        steps with the methods ``solve`` runs in R^n (docs/engine_rn.md).
    X0 : array_like, shape (n, 3), or (n, dim) for a system in R^dim
        Starts.  A row that is not finite, or where H or S is not finite, is
        refused for that trajectory only (``status`` -5); the others run.
    t_span, h, method
        As in ``geomint.solve``, shared by all trajectories; ``h=None`` (the
        default) takes adaptive steps, each trajectory its own; ``method=None``
        chooses as ``solve`` does.  Fixed steps far beyond the dynamics, and a
        method not expected to meet ``rtol``, are flagged as in ``solve``
        (``caveats``, ``step_ratio``, the messages, one ``AccuracyWarning``).
    rtol, atol, first_step, max_step
        Adaptive steps only, as in ``geomint.solve`` (the first step, when not
        given, is chosen per trajectory by the same rule).
    t_eval : array_like, optional
        Times to keep, as in ``geomint.solve``: steps land on them.  Adaptive
        runs keep the states at ``t_eval``, or at the start and ``t_span``'s end
        when it is not given.
    save_every : int or None
        Fixed steps without ``t_eval``: keep every ``save_every``-th step (None:
        the start and the end), as in ``geomint.solve``.  Otherwise 1 or None.
    params : array_like, shape (n, p), optional
        Parameters of each trajectory (default: the system's, for all).
    eps : float or array_like, shape (n,), optional
        eps of each trajectory, or one for all (default: the system's, for all).
    progress : callable, optional
        Called as ``progress(trajectories_done)`` after each chunk.
    backend : "local" or "dask"
        ``"dask"`` runs chunks on ``client`` (a ``dask.distributed.Client``;
        the default client if None).
    chunk : int
        Trajectories per round of kernel calls (per Dask task).
    threads : int, optional
        Threads running the compiled kernel (it releases the GIL) on
        trajectories of a chunk, in turns of ``geomint._kernels.batch.GROUP``; default: the cores numba sees.

    Returns
    -------
    Ensemble
        Trajectory ``i`` equals ``geomint.solve(system, X0[i], ...)`` with the
        same arguments bit for bit (run with its own params and eps; for
        adaptive runs without ``t_eval``, ``solve(..., save_every=None)``).
        Ctrl-C stops between chunks: trajectories not run have status 3.
    """
    if not isinstance(system, MetriplecticSystem):
        raise TypeError(f"`system` must be a geomint.MetriplecticSystem; got {type(system).__name__}.")
    if progress is not None and not callable(progress):
        raise TypeError(f"`progress` must be None or a callable taking the trajectories done; got {progress!r}.")
    if backend not in ("local", "dask"):
        raise ValueError(f"`backend` must be 'local' or 'dask'; got {backend!r}.")
    for name, value in (("chunk", chunk), ("threads", 1 if threads is None else threads)):
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f"`{name}` must be an integer >= 1; got {value!r}.")
    threads_given = threads is not None
    # numba.config's settings are set at import, from the environment: pyright sees no such attribute
    threads = (
        numba.config.NUMBA_NUM_THREADS  # pyright: ignore[reportPrivateImportUsage, reportAttributeAccessIssue]
        if threads is None
        else int(threads)
    )
    X0 = _check_starts(X0, system)
    n = len(X0)
    params = _per_trajectory_params(system, params, n)
    eps = _per_trajectory_eps(system, eps, n)
    integrator = choose_method(method, h, rtol, t_span)
    if not integrator.whole_field and np.any(eps != 0.0):
        raise ValueError(
            f"`method` {integrator!r} integrates the {integrator.flows[0]} flow only, so alone it needs "
            "eps = 0 for every trajectory."
        )
    integrator.check_system(system)
    t0, t_end = check_span(t_span)
    step_data = integrator.lower(system)
    if isinstance(system, MetriplecticSystemN):  # what R^n does not offer, refused as solve refuses it
        check_in_rn(system, integrator, step_data)
    check_direction(integrator, step_data, t_span, t0, t_end)
    t_eval = None if t_eval is None else check_t_eval(t_eval, t0, t_end)
    h, control = check_step_or_control(integrator, h, rtol, atol, first_step, max_step, t0, t_end)
    if h is not None and t_eval is None:
        grid, n_steps = constant_grid(t0, t_end, h, save_every)
        save_every = grid.save_every
        plan = _FixedPlan(t0, t_end, grid)
    else:
        if save_every is not None and (isinstance(save_every, (bool, np.bool_)) or save_every != 1):
            raise ValueError(
                "`save_every` must be 1 or None with adaptive steps (h=None) or t_eval (the rows are "
                f"the times of t_eval, or the start and the end); got {save_every!r}."
            )
        plan = _MarchPlan(t0, *landing_control(integrator, h, control, t0, t_end, t_eval, False), t_eval)
    _check_memory(system, step_data, plan.rows, n)
    if backend == "dask":  # each chunk flagged on its worker (``_dask_task`` runs solve_ensemble)
        ensemble = _on_dask(
            client,
            system,
            X0,
            t_span,
            integrator,
            params,
            eps,
            progress,
            chunk,
            threads if threads_given else 1,
            dict(
                h=h,
                rtol=rtol,
                atol=atol,
                first_step=first_step,
                max_step=max_step,
                t_eval=t_eval,
                save_every=save_every,
            ),
        )
        _warn([c[0] if c else None for c in ensemble.caveats], stacklevel=3)
        return ensemble
    ensemble = _run_local(system, X0, integrator, step_data, params, eps, plan, progress, chunk, threads)
    if h is None:
        caveat = tolerance_caveat(integrator, RTOL if rtol is None else float(rtol), t_end < t0)
        ran = ~np.isin(ensemble.status, (Status.INVALID_START, Status.NOT_RUN))
        return _flagged(ensemble, [caveat if caveat and ran[i] else None for i in range(n)])
    ratio, rate = _step_ratios(system, integrator, h, X0, ensemble.x_final, params, eps)
    return _flagged(ensemble, [step_caveat(integrator, h, r, q) for r, q in zip(ratio, rate)], step_ratio=ratio)


def _step_ratios(system, integrator, h, X0, ends, params, eps):
    """``solve.step_ratios`` of every trajectory, run with its own eps and params: for the ``RATIO_GROUPS``
    distinct (eps, params) with the largest eps (the stiffest, where a step is likeliest to be far beyond the
    dynamics); the others keep NaN."""
    ratio, rate = np.full(len(X0), np.nan), np.full(len(X0), np.nan)
    rows = np.column_stack([eps, params])
    if len(rows) and np.all(rows == rows[0]):  # one (eps, params) for all, as most ensembles: no sort of n rows
        keys, group = rows[:1], np.zeros(len(rows), dtype=np.intp)
    else:
        keys, group = np.unique(rows, axis=0, return_inverse=True)
    stiffest_first = np.argsort(-np.abs(keys[:, 0]), kind="stable")
    for k in stiffest_first[:RATIO_GROUPS]:
        key = keys[k]
        members = np.flatnonzero(group.ravel() == k)
        try:
            own = system.with_effects(
                eps=float(key[0]), params=None if np.array_equal(key[1:], system.params) else key[1:]
            )
        except ValueError:  # params refused here were refused per trajectory by the run: their ratio stays NaN
            continue
        ratio[members], rate[members] = step_ratios(own, integrator, h, X0[members], ends[members])
    return ratio, rate


def _warn(caveats, stacklevel=4):
    """One ``AccuracyWarning`` for the trajectories with a caveat (None: none), naming the first; ``stacklevel``
    points at the caller of ``solve_ensemble``."""
    flagged = [i for i, caveat in enumerate(caveats) if caveat]
    if flagged:
        warnings.warn(
            f"{len(flagged)} of {len(caveats)} trajectories (the first: {flagged[0]}): {caveats[flagged[0]]}",
            AccuracyWarning,
            stacklevel=stacklevel,
        )


def _flagged(ensemble, caveats, **fields):
    """``ensemble`` with each trajectory's caveat (or None) in ``caveats`` and its message; one warning."""
    _warn(caveats)
    messages = tuple(f"{m} {c}" if c else m for m, c in zip(ensemble.messages, caveats))
    return replace(ensemble, messages=messages, caveats=tuple((c,) if c else () for c in caveats), **fields)


def sweep(
    system: MetriplecticSystem,
    X0: npt.ArrayLike,
    t_span: tuple[float, float],
    h: float | None = None,
    method: Integrator | str | None = None,
    *,
    eps: npt.ArrayLike | None = None,
    params: Iterable[npt.ArrayLike] | None = None,
    **options: Any,
) -> Ensemble:
    """Every start of ``X0`` for every combination of ``eps`` (a sequence) and ``params`` (a sequence of parameter
    vectors): one ``solve_ensemble`` over the grid, trajectories ordered eps-major, then params, then starts.

    ``h`` and ``options`` go to ``solve_ensemble`` (``rtol``, ``t_eval``, ``save_every``, ``progress``,
    ``backend``...).  The result's ``eps`` and ``params`` say which point of the grid each trajectory belongs to.
    """
    X0 = _check_starts([X0] if np.ndim(X0) == 1 else X0, system)
    eps_values = [system.eps] if eps is None else list(_validate.reals("eps", eps))
    param_sets = [system.params] if params is None else [np.asarray(p, dtype=np.float64) for p in params]
    grid = [(e, p, x) for e in eps_values for p in param_sets for x in X0]
    return solve_ensemble(
        system,
        np.array([x for _, _, x in grid]),
        t_span,
        h,
        method,
        eps=np.array([e for e, _, _ in grid]),
        params=np.array([p for _, p, _ in grid]),
        **options,
    )


# -- input ---------------------------------------------------------------------------------------
def _check_starts(X0, system):
    """``X0`` as float64 starts of shape (m, dim) (``arguments.check_states``), the message of a system in R^n
    naming its dimension and coordinates."""
    if not isinstance(system, MetriplecticSystemN):
        return check_states(X0, "X0", one=False)
    dim = system.dim
    try:
        return check_states(X0, "X0", one=False, dim=dim)
    except ValueError:  # a shape other than (m, dim): the values converted (check_states refuses others first)
        got = np.asarray(X0, dtype=np.float64).shape
        names = system.variables
        shown = ", ".join(names) if dim <= 6 else f"{', '.join(names[:3])}, ..., {names[-1]}"
        raise ValueError(
            f"`X0` must have shape (m, {dim}): m >= 1 starts, a row of the {dim} coordinates ({shown}) of the "
            f"system in R^{dim}; got shape {got}."
        ) from None


def _check_memory(system, step_data, rows, n):
    """Refuse up front an ensemble whose arrays would not fit in memory (in R^n: the states, outputs and
    workspaces; in R^3 as ``check_memory`` counts them)."""
    if not isinstance(system, MetriplecticSystemN):
        check_memory(rows * n)
        return
    dim = system.dim
    floats = n * (rows * (dim + 3) + workspace_size(step_data, dim, True) + 2 * dim + 2 + system.params.size + 2)
    problem = _validate.memory_problem(8 * floats)
    if problem:
        raise ValueError(
            f"{n} trajectories of {rows} saved states in R^{dim} {problem}; use a larger `save_every` (or None), "
            "or fewer starts per call."
        )


def _per_trajectory_params(system, params, n):
    p = system.params
    if params is None:
        return np.tile(p, (n, 1))
    try:
        array = np.array(params, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise TypeError(f"`params` must be an array of shape (n, {p.size}); got {params!r}.") from None
    if array.shape != (n, p.size):
        raise ValueError(
            f"`params` must have shape (n, p) = ({n}, {p.size}), a row per start; got shape {array.shape}."
        )
    if not np.all(np.isfinite(array)):
        raise ValueError(f"`params` must be finite; row {int(np.argmax(~np.all(np.isfinite(array), axis=1)))} is not.")
    return np.ascontiguousarray(array)


def _per_trajectory_eps(system, eps, n):
    if eps is None:
        return np.full(n, system.eps)
    if np.ndim(eps) == 0:  # one eps for every start
        return _per_trajectory_eps(system, [_validate.real("eps", eps)] * n, n)
    array = _validate.reals("eps", eps)
    if array.shape != (n,):
        raise ValueError(
            f"`eps` must have shape (n,) = ({n},), one per start, or be one number; got shape {array.shape}."
        )
    if np.any(array < 0.0):
        raise ValueError(f"`eps` must be >= 0; got {array[array < 0.0][0]!r}.")
    return array


def _refused(system, X0, params):
    """Per start: None if it can run, else why not (not finite; H or S not finite or raising there)."""
    if _all_can_run(system, X0, params):
        return [None] * len(X0)
    f = system.functions
    reasons = []
    for x, p in zip(X0, params):
        if not np.all(np.isfinite(x)):
            reasons.append(f"x0 = {x.tolist()} is not finite; not run.")
            continue
        try:
            H0, S0 = float(f.H(x.copy(), p)), float(f.S(x.copy(), p))
        except Exception as error:  # noqa: BLE001 - the user's function: its exception is the reason
            reasons.append(f"H or S raised {error!r} at x0 = {x.tolist()}; not run.")
            continue
        reasons.append(
            None
            if np.isfinite(H0) and np.isfinite(S0)
            else f"H and S must be finite at x0; at x0 = {x.tolist()} H = {H0!r}, S = {S0!r}; not run."
        )
    return reasons


def _all_can_run(system, X0, params):
    """Whether every start can run, judged at once: finite, and H and S finite there from one compiled evaluation
    (in R^3, every start with the system's params).  False where one cannot, or where this cannot tell (R^n,
    other params, a function raising): ``_refused`` then goes through the starts one by one for the reasons."""
    if isinstance(system, MetriplecticSystemN) or not np.all(params == system.params):
        return False
    if not np.all(np.isfinite(X0)):
        return False
    try:
        H, S = system._evaluate(X0)[:2]
    except Exception:  # noqa: BLE001 - the user's function: the starts one by one say which and why
        return False
    return bool(np.all(np.isfinite(H)) and np.all(np.isfinite(S)))


# -- the local backend -------------------------------------------------------------------------------
#: positions in the run's arrays: (states, works, t, x, H, S, counters, residuals[, clocks])
_T, _COUNTERS, _CLOCKS = 2, 6, 8


@dataclass(frozen=True)
class _FixedPlan:
    """Fixed steps on the grid ``t0 + k h`` (a ``control.Constant`` controller, as ``solve``'s fixed-step run)."""

    t0: float
    t_end: float
    grid: _control.Constant

    @property
    def rows(self):
        return self.grid.n_steps // self.grid.save_every + 2

    def start(self, n):
        return (np.tile(_layout.new_clock(self.t0), (n, 1)),)

    def run(self, system, step_data, views, first, stride):
        p, o, e, st, wo, tt, xx, HH, SS, co, re, cl = views
        _batch.run_batch(
            system.inlined_model,
            p,
            o,
            e,
            system.hamiltonian,
            step_data,
            self.grid,
            st,
            wo,
            cl,
            np.array([self.t_end]),
            self.grid.n_steps,
            tt,
            xx,
            HH,
            SS,
            co,
            re,
            first,
            stride,
        )

    def unfinished(self, arrays, part):
        return False

    def where_failed(self, i, arrays):
        """``(time the failed step started from, step)`` for the failure message."""
        counters = arrays[_COUNTERS]
        h = self.grid.h
        failed = int(counters[i, _layout.FAILED_STEP]) if counters[i, _layout.STATUS] < 0 else 1
        return self.t0 + (max(failed, 1) - 1) * h, h

    def kept(self, t, rows, status):
        return None


@dataclass(frozen=True)
class _MarchPlan:
    """Adaptive steps, or fixed steps landing on ``t_eval`` (a ``control.Control`` controller, as ``solve``'s run
    landing on stops):
    rows at the stops only."""

    t0: float
    stops: np.ndarray
    control: _control.Control
    t_eval: np.ndarray | None

    #: attempts per trajectory per kernel call (between calls: Ctrl-C)
    BUDGET = 100_000

    @property
    def rows(self):
        return len(self.stops) + 2

    def start(self, n):
        clocks = np.tile(_layout.new_clock(self.t0, self.control.h), (n, 1))
        return (clocks,)

    def run(self, system, step_data, views, first, stride):
        p, o, e, st, wo, tt, xx, HH, SS, co, re, cl = views
        _batch.run_batch(
            system.inlined_model,
            p,
            o,
            e,
            system.hamiltonian,
            step_data,
            self.control,
            st,
            wo,
            cl,
            self.stops,
            self.BUDGET,
            tt,
            xx,
            HH,
            SS,
            co,
            re,
            first,
            stride,
        )

    def unfinished(self, arrays, part):
        counters, clocks = arrays[_COUNTERS], arrays[_CLOCKS]
        return bool(
            np.any((counters[part, _layout.STATUS] == _layout.OK) & (clocks[part, _layout.C_STOP] < len(self.stops)))
        )

    def where_failed(self, i, arrays):
        t, counters, clocks = arrays[_T], arrays[_COUNTERS], arrays[_CLOCKS]
        rows = counters[i, _layout.ROWS]
        return (float(t[i, rows - 1]) if counters[i, _layout.STATUS] < 0 else 0.0), float(clocks[i, _layout.C_H])

    def kept(self, t, rows, status):
        """Per trajectory, the rows ``solve`` returns: the times of ``t_eval`` (and the last state reached by a
        failed run), or all rows (the start and the end) without ``t_eval``."""
        if self.t_eval is None:
            return None
        keep = np.isin(t, self.t_eval) & (np.arange(t.shape[1]) < rows[:, None])
        failed = (status != _layout.OK) & (rows > 0)
        keep[np.flatnonzero(failed), rows[failed] - 1] = True
        return keep


def _run_local(system, X0, integrator, step_data, params, eps, plan, progress, chunk, threads):
    n, dim = X0.shape
    states, works = _run_states(system, X0, step_data)
    t, x, H, S = _batch.empty_outputs(n, plan.rows, dim)
    counters = np.zeros((n, _layout.N_COUNTERS), dtype=np.int64)
    residuals = np.zeros((n, 1))
    if np.all(params == system.params):
        origins = np.tile(system.model.origin, (n, 1))
    else:  # the constant and linear terms of H and S depend on the parameters
        origins = np.array([system._origin(p) for p in params])
    reasons = _refused(system, X0, params)
    counters[[r is not None for r in reasons], _layout.STATUS] = Status.INVALID_START
    arrays = (states, works, t, x, H, S, counters, residuals) + plan.start(n)
    raised_by = {}
    threads = max(1, min(threads, chunk))
    with _user_errors.catching_everywhere() as raised, interrupts() as interrupted, ThreadPoolExecutor(threads) as pool:
        for begin in range(0, n, chunk):
            part = slice(begin, min(n, begin + chunk))
            if interrupted:
                counters[part, _layout.STATUS] = np.where(
                    counters[part, _layout.STATUS] == 0, Status.NOT_RUN, counters[part, _layout.STATUS]
                )
                continue
            snapshot = [a[part].copy() for a in arrays]
            views = [a[part] for a in (params, origins, eps)] + [a[part] for a in arrays]
            while True:
                list(pool.map(lambda first: plan.run(system, step_data, views, first, threads), range(threads)))
                if raised or interrupted or not plan.unfinished(arrays, part):
                    break
            if raised:  # a user function raised on a worker thread: rerun the chunk where the hook can count it
                for array, saved in zip(arrays, snapshot):
                    array[part] = saved
                raised_by.update(_rerun_serially(system, step_data, plan, params, origins, eps, arrays, part))
                raised.clear()
            elif interrupted and plan.unfinished(arrays, part):
                going = counters[part, _layout.STATUS] == _layout.OK
                counters[part, _layout.STATUS] = np.where(going, _layout.INTERRUPTED, counters[part, _layout.STATUS])
            if progress is not None:
                progress(part.stop)
    return _collect(system, integrator, X0, params, eps, plan, arrays, reasons, raised_by)


def _run_states(system, X0, step_data):
    """``(states, works)``, a row per trajectory, as ``chunks.new_run_state`` makes them for ``solve``: ``x0``, no
    compensation, the energy anchor to be taken at the start (NaN), S unknown; the method's workspace (in R^n
    ``step_n``'s)."""
    n, dim = X0.shape
    start = np.where(np.isfinite(X0), X0, 0.0)  # a refused start is never run
    if isinstance(system, MetriplecticSystemN):
        states = np.zeros((n, 2 * dim + 2))
        states[:, :dim] = start
        states[:, -2] = np.nan
        return states, np.zeros((n, workspace_size(step_data, dim, True)))
    states = np.zeros((n, _layout.N_STATE))
    states[:, :3] = start
    states[:, _layout.STATE_ANCHOR] = np.nan  # H at the start (as solve)
    return states, np.zeros((n, workspace_size(step_data, 3, False)))


def _rerun_serially(system, step_data, plan, params, origins, eps, arrays, part):
    """The chunk's trajectories one by one in this thread, each counting its own user-function exceptions."""
    counters = arrays[_COUNTERS]
    raised_by = {}
    for i in range(part.start, part.stop):
        if counters[i, _layout.STATUS] != _layout.OK:
            continue
        one = slice(i, i + 1)
        views = [a[one] for a in (params, origins, eps)] + [a[one] for a in arrays]
        with _user_errors.catching(counters[i]) as raised:
            while True:
                plan.run(system, step_data, views, 0, 1)
                if raised or not plan.unfinished(arrays, one):
                    break
        if raised:
            raised_by[i] = raised[0]
    return raised_by


def _collect(system, integrator, X0, params, eps, plan, arrays, reasons, raised_by):
    t, x, H, S, counters, residuals = arrays[_T:_CLOCKS]
    row_count = counters[:, _layout.ROWS].copy()
    status = counters[:, _layout.STATUS].copy()
    keep = plan.kept(t, row_count, status)
    if keep is not None:  # the rows of t_eval, first in each trajectory
        order = np.argsort(~keep, axis=1, kind="stable")
        t, H, S = (np.take_along_axis(a, order, axis=1) for a in (t, H, S))
        x = np.take_along_axis(x, order[:, :, None], axis=1)
        row_count = np.count_nonzero(keep, axis=1)
        for a in (t, H, S, x):
            a[np.arange(a.shape[1]) >= row_count[:, None]] = np.nan
    used = max(1, int(row_count.max()))
    messages = []
    reached = {}  # a trajectory that reached t_end: its message is that of its steps and rejections
    steps, rejected, ok = counters[:, _layout.STEPS].tolist(), counters[:, _layout.REJECTED].tolist(), int(Status.OK)
    for i, code in enumerate(status.tolist()):
        if code == ok and reasons[i] is None:
            key = (steps[i], rejected[i])
            if key not in reached:
                reached[key] = run_message(ok, None, t[i, : row_count[i]], 0.0, 0.0, counters[i], 0.0, integrator)
            messages.append(reached[key])
            continue
        if reasons[i] is not None:
            messages.append(reasons[i])
            x[i, 0], row_count[i] = X0[i], 1
            continue
        if code == Status.NOT_RUN:
            messages.append("Not run: Ctrl-C stopped the ensemble first.")
            x[i, 0], row_count[i] = X0[i], 1
            continue
        what = None
        if status[i] == _layout.USER_RAISED:
            own = system if np.array_equal(params[i], system.params) else None
            h = plan.where_failed(i, arrays)[1]
            what = (
                raised_message(own, x[i, row_count[i] - 1], h, [raised_by.get(i)])
                if own is not None
                else f"a user function raised {raised_by.get(i)!r}"
            )
        failed = int(counters[i, _layout.FAILED_STEP]) if status[i] < 0 else None
        t_from, h = plan.where_failed(i, arrays)
        messages.append(
            run_message(
                int(status[i]), failed, t[i, : row_count[i]], t_from, h, counters[i], residuals[i, 0], integrator, what
            )
        )
    return Ensemble(
        t=t[:, :used],
        x=x[:, :used],
        H=H[:, :used],
        S=S[:, :used],
        rows=row_count,
        status=status,
        failed_step=np.where(status < 0, counters[:, _layout.FAILED_STEP], 0),
        messages=tuple(messages),
        n_steps=counters[:, _layout.STEPS].copy(),
        n_newton=counters[:, _layout.NEWTON_ITERATIONS].copy(),
        nfev=counters[:, _layout.FIELD_EVALUATIONS].copy(),
        n_rejected=counters[:, _layout.REJECTED].copy(),
        eps=eps,
        params=params,
        method=integrator,
        variables=tuple(system.variables),
        S_direction=float(system.direction),
    )


# -- the Dask backend --------------------------------------------------------------------------------
def _on_dask(client, system, X0, t_span, integrator, params, eps, progress, chunk, threads, options):
    try:
        from distributed import as_completed, default_client
    except ImportError:
        raise ImportError("backend='dask' needs dask.distributed: pip install geomint[dask]") from None
    client = default_client() if client is None else client
    parts = [slice(b, min(len(X0), b + chunk)) for b in range(0, len(X0), chunk)]
    futures = [
        client.submit(_dask_task, system, X0[p], t_span, integrator, params[p], eps[p], threads, options, pure=False)
        for p in parts
    ]
    size = {future.key: p.stop - p.start for future, p in zip(futures, parts)}
    done = 0
    for future in as_completed(futures):
        done += size[future.key]
        if progress is not None:
            progress(done)
    return _concatenate(client.gather(futures), integrator, system)


def _dask_task(system, X0, t_span, integrator, params, eps, threads, options):
    """One chunk on a Dask worker: the local batch kernel (``options``: the step and output keywords).  Its
    caveats travel back in the chunk's result; the client warns once, with the ensemble's own indices."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        return solve_ensemble(
            system, X0, t_span, method=integrator, params=params, eps=eps, chunk=len(X0), threads=threads, **options
        )


def _concatenate(parts, integrator, system):
    used = max(p.t.shape[1] for p in parts)

    def pad(array):
        extra = used - array.shape[1]
        return (
            np.concatenate([array, np.full((array.shape[0], extra) + array.shape[2:], np.nan)], axis=1)
            if extra
            else array
        )

    return Ensemble(
        t=np.concatenate([pad(p.t) for p in parts]),
        x=np.concatenate([pad(p.x) for p in parts]),
        H=np.concatenate([pad(p.H) for p in parts]),
        S=np.concatenate([pad(p.S) for p in parts]),
        **{
            name: np.concatenate([getattr(p, name) for p in parts])
            for name in ("rows", "status", "failed_step", "n_steps", "n_newton", "nfev", "n_rejected", "eps", "params")
        },
        messages=tuple(m for p in parts for m in p.messages),
        method=integrator,
        caveats=tuple(c for p in parts for c in p.caveats),
        step_ratio=None if parts[0].step_ratio is None else np.concatenate([p.step_ratio for p in parts]),
        variables=tuple(system.variables),
        S_direction=float(system.direction),
    )
