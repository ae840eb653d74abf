"""How large round-off is: the size of the terms of H or S, and what a change within it is.

A difference of two values of F carries round-off ~ eps T, T the size of the
*terms* of F, not of F (``discrete_gradient`` module docstring): ``term_scale``
estimates T, ``origin_terms`` the part of it from the constant and linear terms
(measured at the origin, ``layout.Model.origin``), and ``kept`` is the one rule
by which a step, a projection and a pull back judge that H was kept and S did
not rise.
"""

from .jit import inner
from .layout import EPS
from .vec3 import abs_dot


@inner
def term_scale(f_old, f_new, gradient, x, base):
    """``max(|F(x)|, |F(x')|, sum_i |d_i F x_i|, base)``: the size of the terms of F (module docstring);
    ``base`` is ``origin_terms`` at x."""
    return max(abs(f_old), abs(f_new), abs_dot(gradient, x), base)


@inner
def origin_terms(origin, at, x):
    """``|F(0)| + sum_i |d_i F(0) x_i|``, with ``F(0), grad F(0)`` at ``origin[at:at + 4]``
    (``layout.Model.origin``: H at 0, S at 4): the constant and linear terms of F at x."""
    return abs(origin[at]) + abs(origin[at + 1] * x[0]) + abs(origin[at + 2] * x[1]) + abs(origin[at + 3] * x[2])


@inner
def kept(old, new, terms, ulps, direction):
    """``new - old`` within ``ulps`` of ``terms``: in absolute value (``direction = 0``), or not
    rising along ``direction`` (the sign of ``h``: S must not rise forward, not fall backward)."""
    change = direction * (new - old) if direction != 0.0 else abs(new - old)
    return change <= ulps * EPS * terms
