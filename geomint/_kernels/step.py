"""One step of a lowered method (its step data, ``layout``), the step chosen by the data's type.

``step(method, ...)`` picks the step by the *type* of ``method``
(``layout.RungeKutta4``, ``layout.DiscreteGradientStep``,
``layout.ComposedStep``, ``layout.EmbeddedPairStep``) when the loop is
compiled, so a run compiles only what it uses; under ``NUMBA_DISABLE_JIT=1``
the same choice is made in Python.
"""

from numba import njit

from .composition import composed_step
from .composition_n import composed_step_n
from .dg_step import discrete_gradient_step
from .jit import typed_inline
from .layout import (
    NO_PROJECTION,
    P_PROJECTION,
    ComposedStep,
    DiscreteGradientStep,
    EmbeddedPairStep,
    ModelN,
    RungeKutta4,
)
from .runge_kutta import pair_step, rk4_step
from .runge_kutta_n import pair_step_n
from .step_n import discrete_gradient_step_n, rk4_step_n


@njit(inline="always")
def _rk4(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return rk4_step(model, eps, hamiltonian, buf, x, comp, h)


@njit(inline="always")
def _discrete_gradient(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return discrete_gradient_step(
        method.kind,
        method.max_iter,
        method.damped,
        method.compensated,
        method.coeffs,
        model,
        eps,
        hamiltonian,
        buf,
        x,
        comp,
        H_anchor,
        S_x,
        h,
        work,
    )


@njit(inline="always")
def _composed(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return composed_step(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work, 0.0)[0]


@njit(inline="always")
def _pair(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return pair_step(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work, False)[0]


@njit(inline="always")
def _rk4_n(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return rk4_step_n(model, eps, hamiltonian, x, comp, h, work)


@njit(inline="always")
def _discrete_gradient_n(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return discrete_gradient_step_n(
        method.kind.code,
        method.max_iter,
        method.damped.on,
        method.coeffs,
        model,
        eps,
        hamiltonian,
        x,
        comp,
        H_anchor,
        S_x,
        h,
        work,
    )


@njit(inline="always")
def _composed_n(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return composed_step_n(method, model, eps, hamiltonian, x, comp, H_anchor, S_x, h, work, 0.0)[0]


@njit(inline="always")
def _pair_n(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    return pair_step_n(method, model, eps, hamiltonian, x, comp, H_anchor, S_x, h, work, False)[0]


_STEPS = {RungeKutta4: _rk4, DiscreteGradientStep: _discrete_gradient, ComposedStep: _composed, EmbeddedPairStep: _pair}
#: the steps in R^n (``step_n``, ``composition_n``, ``runge_kutta_n``), chosen where the model is a
#: ``layout.ModelN``
_STEPS_N = {
    RungeKutta4: _rk4_n,
    DiscreteGradientStep: _discrete_gradient_n,
    ComposedStep: _composed_n,
    EmbeddedPairStep: _pair_n,
}


def step(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    """One step of ``method`` from ``x`` (a ``layout.StepResult``); ``H_anchor`` is H(x0), ``S_x`` S(x)."""
    steps = _STEPS_N if isinstance(model, ModelN) else _STEPS
    return steps[type(method)](method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work)


@typed_inline(step)
def _step_typed(method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work):
    impl = (_STEPS_N if model.instance_class is ModelN else _STEPS)[method.instance_class]
    return lambda method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work: impl(
        method, model, eps, hamiltonian, buf, x, comp, H_anchor, S_x, h, work
    )


def keeps_S(method, model):
    """Whether a step of ``method`` keeps the S it is given as S at its start, as it keeps its energy anchor: a
    discrete-gradient step, or a program without a projection (whose first discrete-gradient stage takes it), in
    R^3; not a projection (S there is a limit) nor an explicit step (which does not read it).  At eps = 0 the loop
    gives such a step S(x0) (``loop.run``)."""
    if isinstance(model, ModelN):
        return False
    if isinstance(method, DiscreteGradientStep):
        return True
    return isinstance(method, ComposedStep) and method.iopts[P_PROJECTION] == NO_PROJECTION


@typed_inline(keeps_S)
def _keeps_S_typed(method, model):
    if model.instance_class is ModelN or method.instance_class not in (DiscreteGradientStep, ComposedStep):
        return lambda method, model: False
    if method.instance_class is DiscreteGradientStep:
        return lambda method, model: True
    return lambda method, model: method.iopts[P_PROJECTION] == NO_PROJECTION
