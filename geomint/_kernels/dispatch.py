"""Which discrete gradient a kind compiles: by its marker's type when the kernel is compiled, or by its integer
code at run time (a program mixing kinds).

The four discrete gradients of ``discrete_gradient`` behind one signature
``(kind, coeffs, F, grad_F, params, buf, x, x', F(x), F(x'), size, gain, base) -> (dgF, noise)``;
``INLINED`` maps each kind marker (``layout.GonzalezKind`` ...) to its gradient
compiled to be inlined, ``by_code`` chooses by the integer code, and
``discrete_gradient`` is the same choice for Python callers.
"""

import numpy as np
from numba import njit

from .discrete_gradient import average_gradient, gonzalez, itoh_abe, symmetrized_itoh_abe
from .jit import inner
from .layout import AVF, ITOH_ABE, SYMMETRIZED_ITOH_ABE, AVFKind, GonzalezKind, ItohAbeKind, SymmetrizedItohAbeKind
from .vec3 import as_vector, axpy, load, sub


# -- the four discrete gradients of F, one signature: (kind, coeffs, F, grad_F, params, buf, x, x', F(x), F(x'),
#    size, gain, base) -> (dgF, noise); ``kind`` is read only by ``by_code`` -----------------------------------
def _gonzalez_dg(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    dx = sub(x_new, x)
    load(buf, axpy(0.5, dx, x))
    return gonzalez(as_vector(grad_F(buf, params)), f_old, f_new, dx, x_new, gain, base)


def _avf_dg(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    """AVF: the Gauss-Legendre average of grad F on the segment (Quispel, McLaren, J. Phys. A 41
    (2008) 045206, doi:10.1088/1751-8113/41/4/045206), made an exact discrete gradient for any F by
    Gonzalez's projection; the projection's correction vanishes (to round-off) when the rule
    integrates grad F exactly."""
    dx = sub(x_new, x)
    return gonzalez(average_gradient(grad_F, params, buf, x, dx, coeffs), f_old, f_new, dx, x_new, gain, base)


@inner
def _exact(dg_noise, f_old, f_new, x, x_new, gain, base):
    """An Itoh-Abe gradient made exact again where edges switched to derivatives (module docstring):
    Gonzalez's projection of it onto ``dg . dx = F(x') - F(x)``, applied only where the defect exceeds
    its round-off bound (``gonzalez``), so an unswitched gradient is returned as it is."""
    dg, noise = dg_noise
    exact, more = gonzalez(dg, f_old, f_new, sub(x_new, x), x_new, gain, base)
    return exact, max(noise, more)


def _itoh_abe_dg(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    return _exact(
        itoh_abe(F, grad_F, params, buf, x, x_new, f_old, f_new, size, base), f_old, f_new, x, x_new, gain, base
    )


def _symmetrized_dg(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    return _exact(
        symmetrized_itoh_abe(F, grad_F, params, buf, x, x_new, f_old, f_new, size, base),
        f_old,
        f_new,
        x,
        x_new,
        gain,
        base,
    )


_BY_MARKER = {
    GonzalezKind: _gonzalez_dg,
    ItohAbeKind: _itoh_abe_dg,
    SymmetrizedItohAbeKind: _symmetrized_dg,
    AVFKind: _avf_dg,
}


#: each discrete gradient compiled to be inlined (into its own discrete field, below) ...
INLINED = {marker: njit(inline="always")(dg) for marker, dg in _BY_MARKER.items()}


_gonzalez_inlined = INLINED[GonzalezKind]


#: ... and as a call (programs mixing discrete-gradient kinds: ``composition.stage_kind``)
_itoh_abe_called, _symmetrized_called, _avf_called = (inner(dg) for dg in (_itoh_abe_dg, _symmetrized_dg, _avf_dg))


@njit(inline="always")
def by_code(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    """The discrete gradient chosen at run time by the integer code ``kind`` (a program mixing kinds):
    inlined into the discrete field of codes, with Gonzalez's gradient (the usual stage, and a short one) inlined
    too and the others called."""
    if kind == ITOH_ABE:
        return _itoh_abe_called(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base)
    if kind == SYMMETRIZED_ITOH_ABE:
        return _symmetrized_called(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base)
    if kind == AVF:
        return _avf_called(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base)
    return _gonzalez_inlined(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base)


def discrete_gradient(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base):
    """The discrete gradient of F at ``(x, x')`` selected by ``kind``, and its round-off bound (Python callers and
    ``NUMBA_DISABLE_JIT=1``; compiled code reaches them through ``discrete_field``).

    ``kind`` is a kind marker (``layout.GonzalezKind`` ...) or an integer code.
    """
    dg = by_code if isinstance(kind, (int, np.integer)) else _BY_MARKER[type(kind)]
    return dg(kind, coeffs, F, grad_F, params, buf, x, x_new, f_old, f_new, size, gain, base)
