"""Onto the energy level without moving S against its direction, in R^n: the one rule every R^n step ends with.

``settle`` moves a state ``y`` (in place) onto ``H = H_target`` along
``Pi_S grad H(y)``, which leaves S unchanged to first order, and, where S has
then moved against its direction by more than round-off, along
``Pi_H grad S(y)`` back to its limit, which leaves H unchanged to first order;
a few rounds of scalar Newton (``step_n.to_level``).  Near an equilibrium
grad H and grad S are parallel, those directions are ill-conditioned, and the
moves go along the plain gradients (``to_level``).  It serves the
discrete-gradient step (exact under a stopped solve), the projected explicit
steps (``Projected``: the standard projection of Hairer, Lubich & Wanner,
*Geometric Numerical Integration*, section IV.4, with S kept as a constraint)
and the pull back of a composed step onto H(x0) (docs/engine_rn.md).
"""

import numpy as np

from .jit import inner
from .layout import ACCEPT_S_ULPS, ACCEPT_ULPS, EPS
from .step_n import CORRECTION_ROUNDS, term_scale_n, to_level


@inner
def settle(model, y, H_y, H_target, S_limit, against, conserve_s, d, before):
    """Move ``y`` onto ``H = H_target`` with ``S`` not beyond ``S_limit`` against its direction (``against``:
    +1 where S must not rise, -1 where it must not fall); with ``conserve_s`` S is kept at ``S_limit`` either
    way (no dissipation: a Casimir).  ``H_y`` is H(y) (NaN: evaluated here); ``d``, ``before`` are scratch
    vectors.  Returns ``(H(y), S(y), settled, evaluations)``: ``settled`` where H is within ``ACCEPT_ULPS`` of
    its terms of the target and S within ``ACCEPT_S_ULPS`` of its limit (``ACCEPT_ULPS`` either way where it is
    conserved)."""
    p = model.params
    evaluations = 0
    if np.isnan(H_y):
        H_y = model.H(y, p)
        evaluations += 1
    terms_h = term_scale_n(H_target, H_y, model.grad_H(y, p), y, model.origin[0])
    H_y, ev = to_level(model, y, H_y, H_target, True, d, before, EPS * terms_h)
    evaluations += ev
    for _ in range(CORRECTION_ROUNDS):
        S_y = model.S(y, p)
        terms_s = term_scale_n(S_limit, S_y, model.grad_S(y, p), y, model.origin[1])
        if conserve_s:
            if abs(S_y - S_limit) <= EPS * terms_s:
                break
        elif not against * (S_y - S_limit) > 0.5 * EPS * terms_s:
            break
        S_y, ev = to_level(model, y, S_y, S_limit, False, d, before, 0.5 * EPS * terms_s)
        H_y, ev2 = to_level(model, y, model.H(y, p), H_target, True, d, before, EPS * terms_h)
        evaluations += ev + ev2 + 1
    S_y = model.S(y, p)
    terms_s = term_scale_n(S_limit, S_y, model.grad_S(y, p), y, model.origin[1])
    off, s_ulps = (abs(S_y - S_limit), ACCEPT_ULPS) if conserve_s else (against * (S_y - S_limit), ACCEPT_S_ULPS)
    settled = abs(H_y - H_target) <= ACCEPT_ULPS * EPS * terms_h and off <= s_ulps * EPS * terms_s
    return H_y, S_y, settled, evaluations + 2
