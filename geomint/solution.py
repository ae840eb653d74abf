"""The result of ``geomint.solve``."""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Solution:
    """A trajectory with its invariants, status and work counts.

    Field names follow ``scipy.integrate.OdeResult`` where they fit.

    Attributes
    ----------
    t : (n,) array
        Saved times: every ``save_every``-th step, and always the last state
        reached (``t_end`` on success, the last good state on failure).
    x : (n, 3) array
        States at ``t``.
    H, S : (n,) arrays
        Energy and Casimir at ``t``.
    success : bool
        True when the run reached ``t_end`` (``status == 0``).
    status : int
        0: reached ``t_end``; 2: interrupted by Ctrl-C (SIGINT), the states
        up to the interrupt kept; -1: a Newton solve did not converge; -2: a
        step produced a non-finite state; -3: a projection found no point of
        H = H0 that does not raise S; -4: a user function raised an exception
        during a step (named in ``message``).
    message : str
        What happened, naming the failed step and time if any.
    failed_step : int or None
        Index ``k`` of the step ``t_{k-1} -> t_k`` that failed.
    n_steps, n_newton, nfev : int
        Steps taken, Newton iterations, evaluations of the field (gradient triples).
    method : Integrator
        The method used.
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

    @property
    def t_final(self):
        """Time of the last state reached."""
        return float(self.t[-1])

    @property
    def x_final(self):
        """The last state reached (kept even when only every k-th state is saved)."""
        return self.x[-1]

    @property
    def energy_error(self):
        """``max |H - H0| / |H0|`` over the saved states (absolute when H0 = 0)."""
        H0 = self.H[0]
        return float(np.max(np.abs(self.H - H0)) / (abs(H0) if H0 != 0 else 1.0))

    @property
    def S_rises(self):
        """Saved consecutive pairs where S rose by more than round-off (see ``count_S_rises``)."""
        return self.count_S_rises()

    def save(self, path, system=None):
        """Write to ``path`` (.npz with JSON metadata; ``system`` recorded if given): ``geomint.io.save``."""
        from . import io

        return io.save(self, path, system)

    def to_xarray(self, system=None):
        """An ``xarray.Dataset`` of this solution (optional dependency): ``geomint.io.to_xarray``."""
        from . import io

        return io.to_xarray(self, system)

    def count_S_rises(self, ulps=16):
        """Saved consecutive pairs with ``S_{n+1} - S_n > ulps * eps * max(|S_n|, |S_{n+1}|)``."""
        tol = ulps * np.finfo(np.float64).eps * np.maximum(np.abs(self.S[:-1]), np.abs(self.S[1:]))
        return int(np.count_nonzero(np.diff(self.S) > tol))
