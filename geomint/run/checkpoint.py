"""Checkpoints of a fixed-step run: written atomically, resumed only by the same run, bit for bit."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._files import atomic
from .._kernels import layout as _layout

if TYPE_CHECKING:
    import numpy.typing as npt

    from .._kernels.loop import Output
    from ..integrators import Integrator
    from ..model.system import MetriplecticSystem


def check_checkpoint(checkpoint: Any) -> tuple[Path, int] | None:  # refused by name unless (path, steps)
    if checkpoint is None:
        return None
    if not (isinstance(checkpoint, (tuple, list)) and len(checkpoint) == 2):
        raise TypeError(f"`checkpoint` must be None or a pair (path, steps); got {checkpoint!r}.")
    path, steps = checkpoint
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"`checkpoint` path must be a str or a path; got {path!r}.")
    if isinstance(steps, (bool, np.bool_)) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"`checkpoint` steps must be an integer >= 1; got {steps!r}.")
    return Path(path), int(steps)


def run_id(
    system: MetriplecticSystem,
    x0: npt.NDArray[np.float64],
    t0: float,
    t_end: float,
    h: float,
    save_every: int,
    integrator: Integrator,
) -> str:
    """What a checkpoint must match to be resumed: every argument that shapes the run, floats in hex."""
    numbers = [*x0.tolist(), t0, t_end, h, system.eps, *system.params.tolist()]
    return f"{system!r} hamiltonian={system.hamiltonian} {integrator!r} save_every={save_every} " + " ".join(
        float(v).hex() for v in numbers
    )


CHECKPOINT_ARRAYS = ("state", "work", "counters", "residual")


def write_checkpoint(
    path: str | os.PathLike[str],
    run_id: str,
    k_begin: int,
    state: npt.NDArray[np.float64],
    work: npt.NDArray[np.float64],
    out: Output,
) -> None:
    rows = int(out.counters[_layout.ROWS])
    with atomic(path) as temporary:
        np.savez(
            temporary,
            run_id=np.array(run_id),
            k_begin=np.array(k_begin),
            state=state,
            work=work,
            counters=out.counters,
            residual=out.residual,
            t=out.t[:rows],
            x=out.x[:rows],
            H=out.H[:rows],
            S=out.S[:rows],
        )


def resume_checkpoint(
    path: str | os.PathLike[str],
    run_id: str,
    state: npt.NDArray[np.float64],
    work: npt.NDArray[np.float64],
    out: Output,
) -> int:
    """Load a checkpoint into the run's arrays; returns the step to continue from."""
    try:
        with np.load(path, allow_pickle=False) as data:
            saved = {key: data[key] for key in data.files}
    except (OSError, ValueError) as exc:
        raise ValueError(f"`resume` {str(path)!r}: not a readable checkpoint ({exc}).") from None
    if "run_id" not in saved or str(saved["run_id"]) != run_id:
        raise ValueError(
            f"`resume` {str(path)!r} was written by another run; resume with the same system, x0, "
            "t_span, h, method and save_every."
        )
    rows = int(saved["counters"][_layout.ROWS])
    for name, array in (("state", state), ("work", work), ("counters", out.counters), ("residual", out.residual)):
        array[:] = saved[name]
    for name in ("t", "x", "H", "S"):
        getattr(out, name)[:rows] = saved[name]
    return int(saved["k_begin"])
