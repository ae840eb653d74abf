"""The one step loop every method runs through."""

import numpy as np
from numba import njit, types

from .signatures import f64, i64, ivec, mat, model_kernel, vec
from .steps import NON_FINITE, OK, step
from .vec3 import is_finite

# counters layout (int64 array shared with geomint.solve)
STEPS = 0
NEWTON_ITERATIONS = 1
FIELD_EVALUATIONS = 2
STATUS = 3
FAILED_STEP = 4
ROWS = 5
N_COUNTERS = 6


@njit(inline="always")
def _save(out_t, out_x, out_H, out_S, counters, t, x, H_x, S_x):
    row = counters[ROWS]
    out_t[row] = t
    out_x[row, 0], out_x[row, 1], out_x[row, 2] = x
    out_H[row] = H_x
    out_S[row] = S_x
    counters[ROWS] = row + 1


@model_kernel(types.void, f64, types.boolean, i64, vec, ivec, vec, i64, i64, f64, f64, i64, f64, i64, vec, mat, vec, vec, ivec, vec)
def integrate(
    H, grad_H, S, grad_S, J, params, eps, hamiltonian, code, coeffs, iopts,
    state, k_begin, k_end, t0, h, n_steps, h_last, save_every,
    out_t, out_x, out_H, out_S, counters, residual,
):
    """Take steps ``k_begin .. k_end - 1`` of ``n_steps`` from ``state`` (updated in place).

    ``state`` (7,) holds the state, its compensation (the rounding error
    carried by compensated summation, see ``steps.advance``) and the energy
    every step is anchored to, H(x0) (see ``steps.discrete_gradient_step``),
    NaN until the first chunk sets it; the first chunk also saves the initial
    state as row 0.

    Step ``k`` goes from ``t0 + k h`` to ``t0 + (k+1) h`` (the last one has
    length ``h_last``).  States ``k`` with ``k % save_every == 0`` and the final
    one are written to row ``counters[ROWS]`` of the outputs.  A failed step
    stops the loop with the last good state saved and ``counters[STATUS]``,
    ``counters[FAILED_STEP]`` set; ``residual[0]`` holds the last Newton
    correction.  Caller: ``geomint.solve`` (chunks of steps for progress
    reporting); it has validated every argument.
    """
    buf = np.empty(3)
    x = (state[0], state[1], state[2])
    comp = (state[3], state[4], state[5])
    buf[0], buf[1], buf[2] = x
    H_x = H(buf, params)
    S_x = S(buf, params)
    if k_begin == 0:
        state[6] = H_x
        _save(out_t, out_x, out_H, out_S, counters, t0, x, H_x, S_x)
    H_anchor = state[6]
    for k in range(k_begin, k_end):
        hk = h_last if k == n_steps - 1 else h
        x_new, comp_new, H_new, S_new, status, iterations, evaluations, res = step(
            code, H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, comp, H_anchor, S_x, hk
        )
        counters[NEWTON_ITERATIONS] += iterations
        counters[FIELD_EVALUATIONS] += evaluations
        residual[0] = res
        if status == OK and not (is_finite(x_new) and np.isfinite(H_new) and np.isfinite(S_new)):
            status = NON_FINITE
        if status != OK:
            counters[STATUS] = status
            counters[FAILED_STEP] = k + 1
            if k % save_every != 0:
                _save(out_t, out_x, out_H, out_S, counters, t0 + k * h, x, H_x, S_x)
            break
        x, comp, H_x, S_x = x_new, comp_new, H_new, S_new
        counters[STEPS] += 1
        if (k + 1) % save_every == 0 or k + 1 == n_steps:
            t = t0 + (k + 1) * h if k + 1 < n_steps else t0 + (n_steps - 1) * h + h_last
            _save(out_t, out_x, out_H, out_S, counters, t, x, H_x, S_x)
    state[0], state[1], state[2] = x
    state[3], state[4], state[5] = comp
