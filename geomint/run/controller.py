"""The step-size settings of a run: a constant grid, or a ``Control`` (adaptive steps, or fixed steps
landing on the stops of ``t_eval``), validated and built here for ``solve`` and ``solve_ensemble``.

The compiled controllers are ``geomint._kernels.control``'s; this module chooses and fills them: the
tolerances (scaled where step doubling needs it, ``control.proportional_tolerance``), the stops, the grid.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, cast

import numpy as np

from .. import _validate
from .._kernels import control as _control
from .._kernels import layout as _layout
from .arguments import check_save_every, check_step

if TYPE_CHECKING:
    import numpy.typing as npt

    from ..integrators import Integrator

#: scipy's default rtol; atol, when not given, is ``ATOL_PER_RTOL * rtol``: scipy's default 1e-6 at its
#: default rtol, and a floor that moves with rtol, so that rtol alone sets the accuracy
RTOL, ATOL_PER_RTOL = 1e-3, 1e-3

#: float64's machine epsilon
_EPS = float(np.finfo(float).eps)


def step_count(t0: float, t_end: float, h: float) -> int:
    """Number of fixed steps ``solve`` takes from ``t0`` to ``t_end`` (the last one shortened to land on it)."""
    return max(1, math.ceil(abs((t_end - t0) / h) * (1.0 - 4.0 * _EPS)))


def check_step_or_control(
    integrator: Integrator,
    h: float | None,
    rtol: float | None,
    atol: float | None,
    first_step: float | None,
    max_step: float | None,
    t0: float,
    t_end: float,
) -> tuple[float, None] | tuple[None, _control.Control]:
    """``(h, None)``: a fixed step, validated (no controller setting may come with it); or ``(None, Control)``
    for adaptive steps (``h`` None).  Shared by ``solve`` and ``solve_ensemble``."""
    if h is None:
        return None, check_control(integrator, rtol, atol, first_step, max_step, t0, t_end)
    given = [
        name
        for name, v in (("rtol", rtol), ("atol", atol), ("first_step", first_step), ("max_step", max_step))
        if v is not None
    ]
    if given:
        raise ValueError(
            f"`h` = {h!r} fixes the step, so `{given[0]}` cannot be given too; pass h=None for "
            "adaptive steps with rtol/atol."
        )
    return check_step(h, t0, t_end), None


def check_control(
    integrator: Integrator,
    rtol: float | None,
    atol: float | None,
    first_step: float | None,
    max_step: float | None,
    t0: float,
    t_end: float,
) -> _control.Control:
    """The controller's settings, validated; the first step is chosen by ``control.first_step`` when not given."""
    rtol = RTOL if rtol is None else _validate.real("rtol", rtol)
    if not (math.isfinite(rtol) and rtol >= 100 * _EPS):
        raise ValueError(f"`rtol` must be finite and >= 100 eps = {100 * _EPS:.3g}; got {rtol!r}.")
    atol = ATOL_PER_RTOL * rtol if atol is None else _validate.real("atol", atol)
    if not (math.isfinite(atol) and atol >= 0.0):
        raise ValueError(f"`atol` must be finite and >= 0; got {atol!r}.")
    span = abs(t_end - t0)
    max_step = math.inf if max_step is None else _validate.real("max_step", max_step)
    if not max_step > 0.0 or math.isnan(max_step):
        raise ValueError(f"`max_step` must be > 0; got {max_step!r}.")
    if math.isfinite(max_step):  # a bound too small to advance t, or needing over 2**52 steps, would never end
        check_step(max_step, t0, t_end, "max_step")
    if first_step is not None:
        first_step = _validate.real("first_step", first_step)
        if not (math.isfinite(first_step) and 0.0 < first_step <= span):
            raise ValueError(f"`first_step` must be > 0 and at most |t_end - t0| = {span!r}; got {first_step!r}.")
        check_step(first_step, t0, t_end, "first_step")
    estimator, error_order = integrator.error_estimate()
    scale = _control.proportional_tolerance(estimator, integrator.order, rtol)
    return _control.Control(
        True,
        first_step,
        rtol * scale,
        atol * scale,
        max_step,
        estimator,
        float(error_order),
        float(integrator.order),
        True,
    )


def landing_control(
    integrator: Integrator,
    h: float | None,
    control: _control.Control | None,
    t0: float,
    t_end: float,
    t_eval: npt.NDArray[np.float64] | None,
    save_all: bool,
) -> tuple[npt.NDArray[np.float64], _control.Control]:
    """``(stops, Control)`` of a run by the loop (``control.Control``): it lands on the times of ``t_eval`` after ``t0``
    and on ``t_end``; fixed steps ``h`` from each stop on (``control`` None), or adaptive ones whose first
    step, when not given, is 0 here: chosen by ``control.first_step`` when the run starts."""
    if t_eval is None:
        stops = np.array([t_end])
    else:
        stops = np.array([t for t in t_eval if t != t0] or [t_end], dtype=np.float64)
    if stops[-1] != t_end:
        stops = np.append(stops, t_end)
    if control is None:  # fixed steps: h was given (check_step_or_control)
        return stops, _control.Control(
            False,
            math.copysign(cast(float, h), t_end - t0),
            1.0,
            1.0,
            math.inf,
            _layout.NO_ESTIMATE,
            1.0,
            float(integrator.order),
            save_all,
        )
    first = 0.0 if control.h is None else math.copysign(control.h, t_end - t0)
    return stops, control._replace(h=first, save_all=save_all)


def constant_grid(t0: float, t_end: float, h: float, save_every: int | None) -> tuple[_control.Constant, int]:
    """``(Constant, n_steps)``: fixed steps ``h`` (validated) on the grid ``t0 + k h``, the last one shortened to
    land on ``t_end``, every ``save_every``-th state saved (None: the first and the last)."""
    n_steps = step_count(t0, t_end, h)
    h = math.copysign(h, t_end - t0)
    h_last = (t_end - t0) - (n_steps - 1) * h
    return _control.Constant(t0, h, n_steps, h_last, check_save_every(save_every, n_steps)), n_steps
