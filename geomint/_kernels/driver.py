"""The one step loop every method runs through."""

import numpy as np
from numba import njit, types

from .signatures import f64, i64, ivec, mat, model_kernel, vec
from .field import ZERO
from .steps import NON_FINITE, OK, compensated_step
from .vec3 import flush_tiny, is_finite, load, same

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

    Step ``k`` goes from ``t0 + k h`` to ``t0 + (k+1) h`` (the last one has
    length ``h_last``).  States ``k`` with ``k % save_every == 0`` and the final
    one are written to row ``counters[ROWS]`` of the outputs.  A failed step
    stops the loop with the last good state saved and ``counters[STATUS]``,
    ``counters[FAILED_STEP]`` set; ``residual[0]`` holds the last Newton
    correction.

    Discrete-gradient increments are added with Kahan's compensated summation
    (``steps.kahan_add``): the digits of each increment that the state rounds
    away are carried to the next step, so round-off in the sum does not
    random-walk with the number of steps.  The carry restarts at zero with
    each call (one call per chunk of ``geomint.solve``).  Components below
    ``FLUSH * |x|_inf`` are set to zero (``vec3.flush_tiny``), so decaying
    components never reach the slow subnormal range.

    Caller: ``geomint.solve`` (chunks of steps for progress reporting); it has
    validated every argument.
    """
    buf = np.empty(3)
    x = (state[0], state[1], state[2])
    buf[0], buf[1], buf[2] = x
    H_x = H(buf, params)
    S_x = S(buf, params)
    carry = ZERO
    for k in range(k_begin, k_end):
        hk = h_last if k == n_steps - 1 else h
        x_new, carry_new, H_new, S_new, status, iterations, evaluations, res = compensated_step(
            code, H, grad_H, S, grad_S, J, params, eps, hamiltonian, coeffs, iopts, buf, x, carry, H_x, S_x, hk
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
        x_kept, carry = flush_tiny(x_new, carry_new)
        if not same(x_kept, x_new):
            load(buf, x_kept)
            H_new, S_new = H(buf, params), S(buf, params)
        x, H_x, S_x = x_kept, H_new, S_new
        counters[STEPS] += 1
        if (k + 1) % save_every == 0 or k + 1 == n_steps:
            t = t0 + (k + 1) * h if k + 1 < n_steps else t0 + (n_steps - 1) * h + h_last
            _save(out_t, out_x, out_H, out_S, counters, t, x, H_x, S_x)
    state[0], state[1], state[2] = x
