"""The result of ``geomint.solve``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from . import io as _io

if TYPE_CHECKING:
    import os
    from pathlib import Path

    import numpy.typing as npt

    from ..model.system import MetriplecticSystem

#: machine epsilon of float64
EPS = float(np.finfo(np.float64).eps)


class AccuracyWarning(UserWarning):
    """A run that completed but cannot be trusted to the accuracy asked for: a fixed step far beyond the
    field's time scale, or an adaptive method that cannot meet the tolerance given.  The same sentence is
    in the result's ``message`` and ``caveats``."""


@dataclass(frozen=True)
class Solution:
    """A trajectory with its invariants, status and work counts.

    Field names follow ``scipy.integrate.OdeResult`` where they fit.

    Attributes
    ----------
    t : (m,) array
        Saved times: every ``save_every``-th step and ``t_end``, or with
        ``t_eval`` its times only (as scipy's).  A run that ends before
        ``t_end`` (a failed step, a terminal event, Ctrl-C) always keeps the
        last state it reached: the last good state, the event's state.
    x : (m, n) array
        States at ``t`` (n = 3 in R^3; the system's ``dim`` in R^n).
    H, S : (m,) arrays
        Energy and Casimir at ``t`` (for a ``GenericSystem``: the energy E and
        the entropy S, with their own signs).
    success : bool
        True when the run reached ``t_end`` or a terminal event (``status`` 0 or 1).
    status : geomint.Status
        How the run ended, an ``IntEnum`` (so also an int; ``Status.message`` and
        ``Status.advice`` say what it means and what to do): 0 ``OK``, reached
        ``t_end``; 1 ``TERMINATED``, a terminal event stopped the run; 2
        ``INTERRUPTED``, by Ctrl-C (SIGINT), the states up to the interrupt kept;
        -1 ``NEWTON_FAILED``, a Newton solve did not converge; -2 ``NON_FINITE``,
        a step produced a non-finite value; -3 ``PROJECTION_FAILED``, a
        projection found no point of H = H0 that does not raise S; -4
        ``USER_RAISED``, a user function raised an exception during a step
        (named in ``message``); -6 ``STEP_TOO_SMALL``, the error control needed
        a step below the resolution of t; -7 ``NOT_ACCEPTED``, an R^n step's
        solve converged but its state missed H0 or let S move against its
        direction beyond round-off.  (An ensemble's trajectories may also
        have -5 ``INVALID_START`` and 3 ``NOT_RUN``.)
    message : str
        What happened, naming the failed step and time if any.
    failed_step : int or None
        Index ``k`` of the step ``t_{k-1} -> t_k`` that failed.
    n_steps, n_newton, nfev : int
        Steps taken (accepted; up to a terminal event), Newton iterations,
        evaluations of the field (gradient triples).  The work counts
        (``n_newton``, ``nfev``, ``n_rejected``) include the steps the run
        took past a terminal event before it was found: events are looked for
        after each chunk of steps (``geomint.run.chunks``).
    method : Integrator
        The method used.
    n_rejected : int
        Attempted steps an adaptive run rejected (0 with a fixed step).
    t_events, x_events : list of arrays, or None
        With ``events``: per event, the times of its zeros and the states
        there (``(n_k, 3)``; each a step of the method landing on that time).
    sol : callable or None
        With ``dense_output=True``: the cubic Hermite interpolant through the
        steps (``geomint.results.dense.Hermite``), ``sol(t)`` of shape (3,) or (3, m).
    caveats : tuple of str
        Why the states may not be accurate although the run succeeded (each
        sentence also ends ``message`` and was issued as an ``AccuracyWarning``):
        a fixed step far beyond the dynamics (``step_ratio``), or an adaptive
        method that is not expected to meet ``rtol``.  Empty when none.
    step_ratio : float or None
        Fixed steps: ``|h|`` times the field's local rate (the 2-norm of its
        Jacobian up to n = 64, above it the growth of power iterates, a lower
        bound of it: ``geomint.run.solve.local_rate``; the larger at the first
        and the last state; the conservative part only for damped methods).
        Above ``geomint.run.solve.STEP_RATIO_LIMIT`` the run is flagged.  None
        for adaptive steps.
    S_direction : float
        The direction of S of the system the run came from: -1.0 where S never
        rises (the Fish form, R^3 and ``MetriplecticSystemN``), +1.0 where it
        never falls (the entropy of a ``GenericSystem``).

    Notes
    -----
    Counting S's moves (over saved consecutive pairs, in forward time, beyond
    ``ulps`` ulps of S; the properties at 16 ulps):

    * ``S_rises`` / ``count_S_rises(ulps)``: pairs where S rose.  Against the
      direction in the Fish form; the normal direction for GENERIC.
    * ``S_falls`` / ``count_S_falls(ulps)``: pairs where S fell.  Against the
      direction for GENERIC; the normal direction in the Fish form.
    * ``S_against_direction`` / ``count_S_against_direction(ulps)``: pairs where
      S moved against ``S_direction`` (``S_rises`` in the Fish form,
      ``S_falls`` for GENERIC): 0 for a method that keeps S monotone.
    """

    t: np.ndarray
    x: np.ndarray
    H: np.ndarray
    S: np.ndarray
    success: bool
    status: int
    message: str
    failed_step: int | None
    n_steps: int
    n_newton: int
    nfev: int
    method: object
    n_rejected: int = 0
    t_events: list | None = None
    x_events: list | None = None
    sol: object = None
    caveats: tuple = ()
    step_ratio: float | None = None
    S_direction: float = -1.0

    @property
    def y(self) -> np.ndarray:
        """The states in scipy's layout, shape (n, m) (a view of ``x``)."""
        return self.x.T

    @property
    def y_events(self) -> list | None:
        """``x_events``, scipy's name."""
        return self.x_events

    @property
    def t_final(self) -> float:
        """Time of the last saved state: the last state reached, except with ``t_eval`` on a run that
        reached ``t_end``, where it is the last time of ``t_eval`` (see ``t``)."""
        return float(self.t[-1])

    @property
    def x_final(self) -> np.ndarray:
        """The last saved state (``t_final``): the last state reached, kept even when only every k-th state is
        saved, except with ``t_eval`` on a run that reached ``t_end`` (see ``t``)."""
        return self.x[-1]

    @property
    def energy_error(self) -> float:
        """``max |H - H0| / |H0|`` over the saved states (absolute when H0 = 0)."""
        H0 = self.H[0]
        return float(np.max(np.abs(self.H - H0)) / (abs(H0) if H0 != 0 else 1.0))

    @property
    def S_rises(self) -> int:
        """Saved consecutive pairs where S rose by more than round-off (see ``count_S_rises``)."""
        return self.count_S_rises()

    @property
    def S_falls(self) -> int:
        """Saved consecutive pairs where S fell by more than round-off (see ``count_S_falls``): for a GENERIC
        system, the steps against the direction of its entropy."""
        return self.count_S_falls()

    @property
    def S_against_direction(self) -> int:
        """Saved consecutive pairs where S moved against ``S_direction`` by more than round-off: ``S_rises`` in
        the Fish form, ``S_falls`` for GENERIC (see ``count_S_against_direction``)."""
        return self.count_S_against_direction()

    def save(self, path: str | os.PathLike[str], system: MetriplecticSystem | None = None) -> Path:
        """Write to ``path`` (.npz with JSON metadata; ``system`` recorded if given): ``geomint.results.io.save``."""
        return _io.save(self, path, system)

    def to_xarray(self, system: MetriplecticSystem | None = None) -> Any:  # an xarray.Dataset
        """An ``xarray.Dataset`` of this solution (optional dependency): ``geomint.results.io.to_xarray``."""
        return _io.to_xarray(self, system)

    def count_S_rises(self, ulps: float = 16) -> int:
        """Saved consecutive pairs where S rose by more than ``ulps`` ulps in forward time
        (``geomint.diagnostics.S_rises``)."""
        return len(S_rises(self, ulps))

    def count_S_falls(self, ulps: float = 16) -> int:
        """Saved consecutive pairs where S fell by more than ``ulps`` ulps in forward time (``S_falls``)."""
        return len(S_falls(self, ulps))

    def count_S_against_direction(self, ulps: float = 16) -> int:
        """Saved consecutive pairs where S moved against ``S_direction`` by more than ``ulps`` ulps in forward
        time: ``count_S_falls`` for GENERIC (``S_direction`` +1), ``count_S_rises`` otherwise."""
        return self.count_S_falls(ulps) if self.S_direction > 0 else self.count_S_rises(ulps)


def S_rises(sol: Solution, ulps: float = 16) -> npt.NDArray[np.intp]:
    """Indices ``k`` of the saved pairs where S rose in forward time: ``d (S_{k+1} - S_k) > ulps * EPS *
    max(|S_k|, |S_{k+1}|)``, ``d`` the sign of ``t_{k+1} - t_k`` (a backward run sees S rise as t falls).

    ``len(S_rises(sol))`` is ``sol.count_S_rises(ulps)``; the indices say where
    (``sol.t[k + 1]``), for plots.
    """
    return _moves(sol, ulps, 1.0)


def S_falls(sol: Solution, ulps: float = 16) -> npt.NDArray[np.intp]:
    """Indices ``k`` of the saved pairs where S fell in forward time: ``-d (S_{k+1} - S_k) > ulps * EPS *
    max(|S_k|, |S_{k+1}|)``, ``d`` as in ``S_rises``.  For a GENERIC system (``sol.S_direction`` +1) these are the
    steps against the direction of its entropy; ``len(S_falls(sol))`` is ``sol.count_S_falls(ulps)``."""
    return _moves(sol, ulps, -1.0)


def _moves(sol, ulps, sign):
    S = sol.S
    tol = ulps * EPS * np.maximum(np.abs(S[:-1]), np.abs(S[1:]))
    return np.flatnonzero(sign * np.sign(np.diff(sol.t)) * np.diff(S) > tol)


def load(path: str | os.PathLike[str]) -> Solution:
    """The ``Solution`` saved at ``path`` by ``Solution.save`` (``geomint.results.io``); its ``method`` is
    rebuilt from its data form, or kept as that data where it cannot be (a newer geomint, a scipy label)."""
    return Solution(**_io.read(path))
