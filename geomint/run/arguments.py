"""Every argument check ``solve``, ``solve_ensemble`` and ``sweep`` share: state, span, step, ``t_eval``,
``save_every``, ``args``, memory, direction.

Each raises ``TypeError``/``ValueError`` with one grammar: "`x0` must ...; got ...".  The dimension
of a state is taken from the data; geomint integrates systems in R^3, so it must be 3.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _validate
from .._kernels import layout as _layout

if TYPE_CHECKING:
    import numpy.typing as npt

    from ..integrators import Integrator
    from ..model.system import MetriplecticSystem

#: the dimension of the states geomint integrates (R^n will take it from the system)
DIMENSION = 3

#: the most steps one run may take (step indices and counts stay exact in float64 and int64)
MAX_STEPS = 1 << 52


def check_states(value: object, name: str, one: bool = True, dim: int = DIMENSION) -> npt.NDArray[np.float64]:
    """``value`` as float64 states: one state, shape ``(dim,)`` (``one``), or starts, shape ``(m, dim)`` with
    ``m >= 1``; ``dim`` is the system's dimension (``DIMENSION`` in R^3)."""
    shape = f"({dim},)" if one else f"(n, {dim})"
    kind = f"a sequence of {dim} real numbers" if one else f"an array of real starts, shape {shape}"
    if isinstance(value, (str, bytes)):
        raise TypeError(f"`{name}` must be {kind}; got {value!r}.")
    try:
        states = np.array(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise TypeError(f"`{name}` must be {kind}; got {value!r}.") from None
    numeric = isinstance(value, np.ndarray) and value.dtype.kind in "iuf"  # no bool can be among its values
    if not numeric and (
        np.asarray(value).dtype.kind not in "iuf"
        or any(isinstance(v, (bool, np.bool_)) for v in np.asarray(value, dtype=object).ravel())
    ):
        raise TypeError(f"`{name}` must be {kind}; got {value!r}.")  # True is no coordinate, even beside numbers
    if states.ndim != (1 if one else 2) or states.shape[-1] != dim or states.size == 0:
        length = states.shape[-1] if states.ndim else 0
        why = (
            f"states of length {dim}, as the system is in R^{dim} (got length {length})"
            if length != dim
            else ("one state, a 1-D array" if one else "a 2-D array, a row per start")
        )
        raise ValueError(
            f"`{name}` must have shape {shape}{'' if one else ' with n >= 1'}; got shape {states.shape}: {why}."
        )
    return states


def check_state(
    x0: npt.ArrayLike, system: MetriplecticSystem | None = None, name: str = "x0", functions: bool = True
) -> npt.NDArray[np.float64]:
    """One finite state (``check_states``) of ``system``'s dimension, with H and S finite there when ``system``
    is given and ``functions`` (False: the caller checks them, ``solve`` from its run's first row)."""
    x = check_states(x0, name, dim=getattr(system, "dim", DIMENSION))
    if not all(map(math.isfinite, x.tolist())):  # (for a few coordinates, a fifth of numpy's isfinite and all)
        raise ValueError(f"`{name}` must be finite; got {x.tolist()}.")
    if system is not None and functions:
        H0, S0 = system.H_and_S(x)
        if not (np.isfinite(H0) and np.isfinite(S0)):
            raise ValueError(f"H and S must be finite at `{name}`; at {name} = {x.tolist()} H = {H0!r}, S = {S0!r}.")
    return x


def check_span(t_span: Any) -> tuple[float, float]:  # refused by name unless a pair of reals
    if type(t_span) is tuple and len(t_span) == 2 and type(t_span[0]) is float and type(t_span[1]) is float:
        t0, t_end = t_span  # the common case, checked as below without numpy's conversions
    else:
        if isinstance(t_span, (str, bytes)) or np.ndim(t_span) != 1 or len(t_span) != 2:
            raise ValueError(f"`t_span` must be a pair (t0, t_end) of real numbers; got {t_span!r}.")
        t0, t_end = (_validate.real("t_span", t) for t in t_span)
    if not (math.isfinite(t0) and math.isfinite(t_end)):
        raise ValueError(f"`t_span` must be finite; got {t_span!r}.")
    if t_end == t0:
        raise ValueError(f"`t_span` must satisfy t_end != t0; got {t_span!r}.")
    return t0, t_end


def check_step(h: float, t0: float, t_end: float, name: str = "h") -> float:
    """A step ``h`` (the argument ``name``: ``h``, ``first_step`` or ``max_step``): finite, > 0, at most 2**52
    of them over the span, and large enough to advance the time at both ends of it in float64."""
    h = _validate.real(name, h)
    if not (math.isfinite(h) and h > 0.0):
        raise ValueError(f"`{name}` must be finite and > 0; got {h!r}.")
    steps = abs(t_end - t0) / h
    if not steps <= MAX_STEPS:
        raise ValueError(
            f"`{name}` = {h!r} needs {steps:.3g} steps over t_span = ({t0!r}, {t_end!r}); at most 2**52 are "
            f"allowed. Use a larger `{name}` or a shorter span."
        )
    if t0 + h == t0 or t_end - h == t_end:
        raise ValueError(
            f"`{name}` = {h!r} cannot advance the time {max(abs(t0), abs(t_end))!r} in float64; use a larger "
            f"`{name}` or shift t_span towards 0."
        )
    return h


def check_save_every(save_every: int | None, n_steps: int) -> int:
    if save_every is None:
        return n_steps
    if isinstance(save_every, (bool, np.bool_)) or not isinstance(save_every, (int, np.integer)) or save_every < 1:
        raise ValueError(f"`save_every` must be an integer >= 1 or None; got {save_every!r}.")
    return int(min(save_every, n_steps))


#: what to do about a run whose saved states do not fit: fixed steps on a grid, and runs that keep every step
SAVE_FEWER = "use a larger `save_every` (or None)"
KEEP_FEWER = "pass save_every=None (only t_end kept) or t_eval (only its times kept), or a shorter span"


def check_memory(rows: int, advice: str = SAVE_FEWER) -> None:
    """Refuse a run whose saved states would not fit in memory, saying what to do (``advice``)."""
    problem = _validate.memory_problem(rows * 6 * 8)
    if problem:
        raise ValueError(f"saving {rows} states {problem}; {advice}.")


def check_t_eval(t_eval: npt.ArrayLike, t0: float, t_end: float) -> npt.NDArray[np.float64]:
    values = _validate.reals("t_eval", t_eval)
    if values.size == 0:
        raise ValueError("`t_eval` must hold at least one time; got an empty sequence.")
    lo, hi = min(t0, t_end), max(t0, t_end)
    outside = values[(values < lo) | (values > hi)]
    if outside.size:
        raise ValueError(f"`t_eval` must lie within t_span = ({t0!r}, {t_end!r}); got {float(outside[0])!r}.")
    steps = np.diff(values) * math.copysign(1.0, t_end - t0)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        order = "increasing" if t_end > t0 else "decreasing (t_span runs backward)"
        raise ValueError(
            f"`t_eval` must be strictly {order}; got {float(values[k])!r} then {float(values[k + 1])!r} at index {k}."
        )
    check_memory(values.size + 2)
    return values


def with_args(system: MetriplecticSystem, args: npt.ArrayLike) -> MetriplecticSystem:
    values = _validate.reals("args", args)
    if values.shape != system.params.shape:
        raise ValueError(
            f"`args` must have {system.params.size} values, as the system's params; got {values.size}: "
            f"{values.tolist()}."
        )
    return system.with_effects(params=values)


def reversible(step_data: tuple) -> bool:
    """Backward steps are the same formulas with ``h < 0``: RK4, the pairs, the discrete-gradient family.
    Projections and the compositions' S safeguard assume S falls along the step."""
    if isinstance(step_data, _layout.EmbeddedPairStep):
        return step_data.projection == _layout.NO_PROJECTION
    return isinstance(step_data, (_layout.RungeKutta4, _layout.DiscreteGradientStep))


def check_direction(integrator: Integrator, step_data: tuple, t_span: Any, t0: float, t_end: float) -> None:
    """Refuse a backward ``t_span`` for a method that cannot step backward (``reversible``)."""
    if t_end < t0 and not reversible(step_data):
        raise ValueError(
            f"`t_span` = {t_span!r} runs backward, which {integrator!r} cannot: its S safeguard or "
            "projection keeps S from rising, as S must backward. Use Gonzalez(), another discrete "
            "gradient, RK4() or a Runge-Kutta pair."
        )
