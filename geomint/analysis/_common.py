"""What the analysis modules share: the fields by name, and the checks of their arguments."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy.typing as npt

    from ..model.system import MetriplecticSystem

FIELDS = ("xi", "xi_P", "xi_g")
ZERO = 1e-9  # a residual at most this fraction of its scale counts as zero


def field_of(system: MetriplecticSystem, field: str) -> Callable[[npt.ArrayLike], npt.NDArray[np.float64]]:
    """``X -> field(X)`` at many points, shape ``(n, 3)``, for ``field`` in ``FIELDS``."""
    method = {"xi": system.xi, "xi_P": system.xi_P, "xi_g": system.xi_g}[field]
    return lambda X: np.atleast_2d(method(X))


def check_field(field: str) -> str:
    if field not in FIELDS:
        raise ValueError(f"`field` must be one of {', '.join(FIELDS)}; got {field!r}.")
    return field


def check_level(H0: float) -> float:
    try:
        value = float(H0)
    except (TypeError, ValueError):
        raise TypeError(f"`H0` must be a real number; got {H0!r}.") from None
    if not np.isfinite(value):
        raise ValueError(f"`H0` must be finite; got {H0!r}.")
    return value


def as_points(X: npt.ArrayLike, dim: int = 3) -> npt.NDArray[np.float64]:
    """``X`` as a float64 array of shape ``(m, dim)`` (one point ``(dim,)`` becomes ``(1, dim)``)."""
    try:
        X = np.atleast_2d(np.asarray(X, dtype=np.float64))
    except (TypeError, ValueError):
        raise TypeError(f"`x` must be an array of real numbers of shape ({dim},) or (n, {dim}); got {X!r}.") from None
    if X.ndim != 2 or X.shape[1] != dim:
        raise ValueError(f"`x` must have shape ({dim},) or (n, {dim}); got shape {X.shape}.")
    return X


def dimension(system: MetriplecticSystem) -> int:
    """The dimension n of the system's state (3 for the systems in R^3)."""
    return int(getattr(system, "dim", 3))


def require_three(system: MetriplecticSystem, what: str, instead: str) -> None:
    """Refuse a system in R^n (n != 3) for an [R3] tool, naming ``what`` and the R^n tool to use ``instead``."""
    n = dimension(system)
    if n != 3:
        raise TypeError(f"{what} works on systems in R^3; `system` is in R^{n}: use {instead}.")
