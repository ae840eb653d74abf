"""The structure of a system checked at sample points: gradients, Casimir, Jacobi, skew P, declared exact flows.

At six points drawn uniformly from ``[-1, 1]^3`` (a fixed seed): ``grad H``
and ``grad S`` against central differences of step 1e-6, ``grad S x J = 0``
(S a Casimir), ``J . curl J = 0`` (Jacobi, with ``curl J`` by central
differences), ``P = -P^T`` when P is given as a matrix; each within 1e-5
relative.  A declared exact flow (``exact_flows``) is checked the same way.
A violation raises ``ValueError`` naming the function, the rule and the point.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _user_errors, _validate

SAMPLES = np.random.default_rng(20261121).uniform(-1.0, 1.0, size=(6, 3))


def check_structure(system: Any) -> None:  # a MetriplecticSystem (model.system imports this module)
    """Gradients vs finite differences, Casimir ``grad S x J = 0``, Jacobi, skew P, at sample points."""
    try:
        _check_samples(system)
    except _user_errors.UserFunctionError as error:
        raise _user_errors.UserFunctionError(
            error.function,
            error.x,
            error.__cause__,
            "The structure checks evaluate the functions at sample points in [-1, 1]^3 and 1e-6 around them: "
            "return NaN where a function is undefined there, or pass check=False.",
        ) from error.__cause__


def _check_samples(system):
    H, S, grad_H, grad_S, J = system._evaluate(SAMPLES)
    finite = np.isfinite(H) & np.isfinite(S) & np.all(np.isfinite(np.hstack([grad_H, grad_S, J])), axis=1)
    points = SAMPLES[finite]
    if points.size == 0:
        return
    step = 1e-6
    for label, values, grads in (("grad_H", H, grad_H), ("grad_S", S, grad_S)):
        fd = np.stack(
            [
                (_fn_values(system, points + step * e, label) - _fn_values(system, points - step * e, label))
                / (2 * step)
                for e in np.eye(3)
            ],
            axis=1,
        )
        # central differences carry round-off ~ eps |F| / step: allow 1e-7 |F| besides 1e-5 relative
        size = np.maximum(np.abs(grads[finite]), np.abs(fd)).max(axis=1) + 1e-2 * np.abs(values[finite])
        _require(label, points, grads[finite], fd, "match finite differences of " + label[5:], scale=size)
    casimir = np.cross(grad_S[finite], J[finite])
    _require(
        "J",
        points,
        casimir,
        np.zeros_like(casimir),
        "satisfy grad S x J = 0 (S must be a Casimir of P)",
        scale=np.linalg.norm(grad_S[finite], axis=1) * np.linalg.norm(J[finite], axis=1),
    )
    from . import axial  # [R3], imported on use: the model's core imports no 3-D-only module

    curl = axial.curl(system, points, step)
    jacobi = np.sum(J[finite] * curl, axis=1)
    _require(
        "J",
        points,
        jacobi,
        np.zeros_like(jacobi),
        "satisfy Jacobi, J . curl J = 0",
        scale=np.linalg.norm(J[finite], axis=1) * (np.linalg.norm(curl, axis=1) + 1.0),
    )
    if system.functions.poisson_form == "matrix":
        for x in points:
            P = np.asarray(system.functions.poisson(x.copy(), system._params))
            if not np.allclose(P, -P.T, rtol=1e-12, atol=1e-12 * np.abs(P).max()):
                raise ValueError(f"`P` must be skew-symmetric; at x = {x.tolist()} it is {P.tolist()}.")


def _fn_values(system, X, label):
    return system._evaluate(X)[0 if label == "grad_H" else 1]


def _require(name, points, got, want, rule, scale=None):
    got, want = np.asarray(got), np.asarray(want)
    if scale is None:
        scale = np.max(np.abs(want), axis=-1) if want.ndim > 1 else np.abs(want)
    bad = np.abs(got - want).reshape(len(points), -1).max(axis=1) > 1e-5 * (np.asarray(scale) + 1e-8)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ValueError(
            f"`{name}` must {rule}; at x = {points[i].tolist()} it gives {np.atleast_1d(got[i]).tolist()} "
            f"(expected {np.atleast_1d(want[i]).tolist()}). Pass check=False to skip this check."
        )


# -- declared exact sub-flows ------------------------------------------------------------
_EXACT_FLOW_DATA = {"rigid_body_flow": 3, "rotor_splitting": 0, "oscillator_rotation": 0}


def declared_exact_flows(exact_flows: dict[str, Any] | None) -> dict[str, tuple[float, ...]]:
    """``exact_flows`` (a dict ``{name: data}`` or None) checked as a declaration: known names, data as floats."""
    if exact_flows is None:
        return {}
    if not isinstance(exact_flows, dict):
        raise TypeError(f"`exact_flows` must be a dict {{name: data}}; got {type(exact_flows).__name__}.")
    checked = {}
    for name, data in exact_flows.items():
        if name not in _EXACT_FLOW_DATA:
            raise ValueError(f"`exact_flows` names must be among {sorted(_EXACT_FLOW_DATA)}; got {name!r}.")
        values = _validate.reals(f"exact_flows[{name!r}]", data)
        if values.size != _EXACT_FLOW_DATA[name]:
            raise ValueError(f"`exact_flows[{name!r}]` must hold {_EXACT_FLOW_DATA[name]} numbers; got {data!r}.")
        checked[name] = tuple(float(v) for v in values)
    return checked


def _check_rigid_body(system, moments):
    if not all(m > 0.0 for m in moments):
        raise ValueError(f"`exact_flows['rigid_body_flow']` must be positive moments (a, b, c); got {moments!r}.")
    _, _, grad_H, _, J = system._evaluate(SAMPLES)
    _require(
        "exact_flows",
        SAMPLES,
        grad_H,
        SAMPLES * np.array(moments),
        f"hold for rigid_body_flow: grad H = (a x, b y, c z) with (a, b, c) = {moments}",
    )
    _require("exact_flows", SAMPLES, J, SAMPLES, "hold for rigid_body_flow: J = m")


def _check_rotors(system, data):
    _, _, _, _, J = system._evaluate(SAMPLES)
    _require("exact_flows", SAMPLES, J, SAMPLES, "hold for rotor_splitting: J = m")
    step = 1e-6
    for j, e in enumerate(np.eye(3)):
        column = (system.grad_H(SAMPLES + step * e) - system.grad_H(SAMPLES - step * e)) / (2 * step)
        mixed = np.delete(column, j, axis=1)
        _require(
            "exact_flows",
            SAMPLES,
            mixed,
            np.zeros_like(mixed),
            "hold for rotor_splitting: H separable, d grad_H_i / d x_j = 0 for i != j",
            scale=np.abs(column).max(axis=1) + 1.0,
        )


def _check_rotation(system, data):
    _, _, grad_H, _, J = system._evaluate(SAMPLES)
    _require("exact_flows", SAMPLES, grad_H, SAMPLES, "hold for oscillator_rotation: grad H = x")
    _require("exact_flows", SAMPLES, J, np.broadcast_to(J[0], J.shape), "hold for oscillator_rotation: J constant")


_EXACT_FLOW_CHECKS = {
    "rigid_body_flow": _check_rigid_body,
    "rotor_splitting": _check_rotors,
    "oscillator_rotation": _check_rotation,
}


def check_exact_flows(system: Any) -> None:  # a MetriplecticSystem (model.system imports this module)
    """Each exact flow ``system.exact_flows`` declares holds at the sample points."""
    for flow, data in system.exact_flows.items():
        _EXACT_FLOW_CHECKS[flow](system, data)
