"""2-D Euler: the vorticity field of a state of the N x N truncation on the torus [0, 2 pi)^2
(``geomint.systems.euler_vorticity``, trigonometric interpolation on a finer grid)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..systems import euler_vorticity
from ._common import new_axis

if TYPE_CHECKING:
    import numpy.typing as npt
    from matplotlib.axes import Axes
    from matplotlib.image import AxesImage

#: the colour map of vorticity: diverging, white at 0 (positive red, negative blue)
CMAP = "RdBu_r"


def vorticity_field(
    x: npt.ArrayLike,
    N: int,
    ax: Axes | None = None,
    *,
    size: int = 96,
    vmax: float | None = None,
    title: str | None = None,
) -> AxesImage:
    """The vorticity ``omega(theta_1, theta_2)`` of the Euler state ``x`` (n = N^2 - 1) as an image: theta_1
    across, theta_2 up, both in [0, 2 pi) radians; the colour scale symmetric about 0, ``[-vmax, vmax]``
    (default the field's own largest |omega|).  Returns the image (for a colorbar)."""
    ax = new_axis(ax)
    field = euler_vorticity(np.asarray(x, dtype=np.float64), N, size=max(size, N))
    vmax = float(np.max(np.abs(field))) if vmax is None else vmax
    vmax = vmax if vmax > 0.0 else 1.0
    image = ax.imshow(
        field.T,
        origin="lower",
        extent=(0.0, 2 * np.pi, 0.0, 2 * np.pi),
        cmap=CMAP,
        vmin=-vmax,
        vmax=vmax,
        interpolation="bilinear",
    )
    ticks = [0.0, np.pi, 2 * np.pi]
    ax.set_xticks(ticks, ["0", "π", "2π"])
    ax.set_yticks(ticks, ["0", "π", "2π"])
    ax.set_xlabel("θ₁ [rad]")
    ax.set_ylabel("θ₂ [rad]")
    if title is not None:
        ax.set_title(title, fontsize=9)
    return image
