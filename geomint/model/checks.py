"""The structure of a system checked at sample points: gradients, Casimir, Jacobi, skew P, declared exact flows.

At six points drawn uniformly from ``[-1, 1]^3`` (a fixed seed): ``grad H``
and ``grad S`` against central differences of step 1e-6, ``grad S x J = 0``
(S a Casimir), ``J . curl J = 0`` (Jacobi, with ``curl J`` by central
differences), ``P = -P^T`` when P is given as a matrix; each within 1e-5
relative.  A declared exact flow (``exact_flows``) is checked the same way.
A violation raises ``ValueError`` naming the function, the rule and the point.

In R^n (``check_structure_n``) the points are the system's samples (default
six uniform in ``[-1, 1]^n``, a seed per n, or the user's ``samples``):
gradients along the axes (n <= 32) or 32 random directions against central
differences, the same 1e-5 relative; P skew and a user's metric symmetric to
1e-10 of their largest entry; ``P grad S = 0`` and ``G grad H = 0`` to 1e-5 of
``max_i sum_j |A_ij| |v_j|``; the metric semidefinite of the form's sign, its
wrong-signed eigenvalues within 1e-8 of the largest |eigenvalue|.  An operator
given as an action (``P_apply``, ``metric_apply``; GENERIC's ``L_apply``,
``M_apply``) is checked on its matrix formed column by column where n <= 32,
and by 8 random probes where n is larger: ``u . A v = -/+ v . A u`` to 1e-10
of ``|u| |A v| + |v| |A u|``, ``v . G v`` of the form's sign to 1e-8 of
``|v| |G v|``, and the null products (one action each) as for matrices, to
1e-5 of ``|A|_est |v|`` (``|A|_est`` the largest ``|A u| / |u|`` of the
probes).  Jacobi is not checked in R^n (Galerkin truncations are not Jacobi, and the field needs only
skewness and the Casimir).
"""

from __future__ import annotations

import numbers
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
        raise ValueError(
            f"the structure checks found the functions not finite at any of their {len(SAMPLES)} sample points in "
            f"[-1, 1]^3 (e.g. x = {SAMPLES[0].tolist()}), so nothing could be checked; pass check=False to build "
            "the system unchecked (geomint.testing's assertions check it where it is defined)."
        )
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


# -- systems in R^n ------------------------------------------------------------------------
#: directional derivatives checked per sample point: the coordinate axes up to this n, random directions above
_DIRECTIONS = 32
#: skew and symmetric matrices to this fraction of their largest entry (sums of n terms round)
_MATRIX_RTOL = 1e-10
#: a semidefinite metric's eigenvalues of the wrong sign to this fraction of its largest |eigenvalue|
_SIGN_RTOL = 1e-8


def check_dim(dim: Any) -> int:
    """``dim`` as an int >= 2, or a TypeError/ValueError naming it."""
    if isinstance(dim, (bool, np.bool_)) or not isinstance(dim, numbers.Integral):
        raise TypeError(f"`dim` must be an integer >= 2 (the dimension n of the state); got {dim!r}.")
    if dim < 2:
        raise ValueError(f"`dim` must be an integer >= 2 (the dimension n of the state); got {dim!r}.")
    return int(dim)


def samples_n(dim: int, count: int = 6) -> np.ndarray:
    """``count`` sample points drawn uniformly from ``[-1, 1]^dim`` (a fixed seed per dimension)."""
    return np.random.default_rng([20261121, dim]).uniform(-1.0, 1.0, size=(count, dim))


def check_samples(samples: Any, dim: int) -> np.ndarray:
    """``samples`` (None: ``samples_n(dim)``) as a contiguous (k, dim) float64 array, k >= 1, all finite, or a
    TypeError/ValueError naming it."""
    if samples is None:
        return samples_n(dim)
    try:
        array = np.array(samples, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"`samples` must be an array (k, n) of states in the domain; got {samples!r}.") from None
    if array.ndim == 1 and array.size == dim:
        array = array[None, :]
    if array.ndim != 2 or array.shape[1] != dim or array.shape[0] == 0:
        raise ValueError(f"`samples` must have shape (k, n) with k >= 1 and n = dim = {dim}; got shape {array.shape}.")
    if not np.all(np.isfinite(array)):
        raise ValueError("`samples` must be finite states.")
    return np.ascontiguousarray(array)


def shown(x: np.ndarray) -> str:
    """A state for a message: all its entries up to n = 8, else the first and last few and n."""
    x = np.asarray(x)
    return str(x.tolist()) if x.size <= 8 else f"{np.array2string(x, threshold=8, edgeitems=3)} (n = {x.size})"


def check_structure_n(system: Any) -> None:  # a MetriplecticSystemN (model.system_n imports this module)
    """The structure of a system in R^n at its sample points (``system._samples``): gradients against central
    differences, P skew, ``P grad S = 0``, and a user's metric symmetric, semidefinite of the right sign
    (Fish: G <= 0; GENERIC: M >= 0) and annihilating ``grad H``.  Jacobi is not checked: the field needs only
    skewness and the Casimir (a Galerkin truncation of 2-D Euler is skew and degenerate but not Jacobi).

    Each violation raises ``ValueError`` naming the argument (as the user wrote it: ``grad_E``, ``L``, ``M``
    for GENERIC), the rule and the residual against the size of its terms.
    """
    try:
        _check_samples_n(system)
    except _user_errors.UserFunctionError as error:
        raise _user_errors.UserFunctionError(
            error.function,
            error.x,
            error.__cause__,
            "The structure checks evaluate the functions at sample points (default: uniform in [-1, 1]^n) and "
            "1e-6 around them: give `samples=` (an array (k, n) of states in the domain), return NaN where a "
            "function is undefined, or pass check=False.",
        ) from error.__cause__


def _check_samples_n(system):
    names, n = system._names, system.dim
    rows = [_evaluate_operators(system, x) for x in system._samples]
    finite = [all(np.all(np.isfinite(v)) for v in row if v is not None and not callable(v)) for row in rows]
    if not any(finite):
        raise ValueError(
            f"`samples`: the functions are not finite at any of the {len(rows)} sample points (e.g. x = "
            f"{shown(system._samples[0])}); give `samples=` (an array (k, n) of states where they are defined) or "
            "pass check=False."
        )
    points = [x for x, ok in zip(system._samples, finite) if ok]
    rows = [row for row, ok in zip(rows, finite) if ok]
    directions = np.eye(n) if n <= _DIRECTIONS else _unit_directions(n)
    step = 1e-6
    for role, value_role, index in (("grad_H", "H", 0), ("grad_S", "S", 1)):
        for x, row in zip(points, rows):
            value, grad = row[index], row[index + 2]
            fd = np.array(
                [
                    (system._call(value_role, x + step * v) - system._call(value_role, x - step * v)) / (2 * step)
                    for v in directions
                ]
            )
            along = directions @ grad
            # central differences carry round-off ~ eps |F| / step: allow 1e-7 |F| besides 1e-5 relative
            size = max(np.abs(along).max(), np.abs(fd).max()) + 1e-2 * abs(value)
            worst = int(np.argmax(np.abs(along - fd)))
            if abs(along[worst] - fd[worst]) > 1e-5 * (size + 1e-8):
                where = f"e_{worst}" if n <= _DIRECTIONS else f"a random unit vector (#{worst})"
                raise ValueError(
                    f"`{names[role]}` must match finite differences of {names[value_role]}; at x = {shown(x)} the "
                    f"derivative along {where} is {along[worst]!r} by `{names[role]}` but {fd[worst]!r} by finite "
                    f"differences (terms of size {size:.3g}). Pass check=False to skip this check."
                )
    for x, (_, _, grad_H, grad_S, P, M) in zip(points, rows):
        name = names["P" if system.functions.P is not None else "P_apply"]
        letter = names["P"]
        if callable(P):
            _probe(name, x, P, -1, "be skew-symmetric (P = -P^T)", n)
            _require_null_action(name, x, P, grad_S, f"satisfy {letter} grad S = 0 (S must be a Casimir of it)", n)
        else:
            _require_matrix(name, x, P, -1, "be skew-symmetric (P = -P^T)")
            _require_null(name, x, P, grad_S, f"satisfy {letter} grad S = 0 (S must be a Casimir of it)")
        if M is None:
            continue
        name = names["M" if system.functions.M is not None else "M_apply"]
        letter = "G" if names["M"] == "metric" else names["M"]
        rule = f"satisfy {letter} grad {names['H']} = 0 ({names['H']} must be conserved)"
        if callable(M):
            _probe(name, x, M, +1, "be symmetric", n, system.direction)
            _require_null_action(name, x, M, grad_H, rule, n)
        else:
            _require_matrix(name, x, M, +1, "be symmetric")
            _require_sign(name, x, M, system.direction)
            _require_null(name, x, M, grad_H, rule)


#: probes of an operator given as an action where n > _DIRECTIONS
_PROBES = 8


def _evaluate_operators(system, x):
    """``(H, S, grad H, grad S, P, M)`` at ``x``, P and M as matrices (formed column by column from an action
    where n <= _DIRECTIONS), or as the action ``v -> A v`` itself where an action is given and n is larger; M None
    for the paper's metric."""
    values = system._evaluate_one(x)[:4]
    operators = []
    for role in ("P", "M"):
        given_matrix = getattr(system.functions, role) is not None
        given_action = getattr(system.functions, role + "_apply") is not None
        if not (given_matrix or given_action):
            operators.append(None)
        elif given_action and system.dim > _DIRECTIONS:
            operators.append(lambda v, role=role: system._call(role + "_apply", x, v))
        else:
            operators.append(system._call(role, x))
    return (*values, *operators)


def _probe(name, x, apply, sign, rule, n, direction=None):
    """An action ``apply`` checked by random probes: ``u . A v = -sign v . A u`` (skew: sign -1, symmetric: +1)
    to ``_MATRIX_RTOL`` of ``|u| |A v| + |v| |A u|``; with ``direction``, ``v . A v`` of its sign (Fish: <= 0,
    GENERIC: >= 0) to ``_SIGN_RTOL`` of ``|v| |A v|``."""
    rng = np.random.default_rng([20261123, n])
    for k in range(_PROBES):
        u, v = rng.normal(size=(2, n))
        Au, Av = apply(u), apply(v)
        residual = abs(u @ Av - sign * (v @ Au))
        size = np.linalg.norm(u) * np.linalg.norm(Av) + np.linalg.norm(v) * np.linalg.norm(Au)
        if residual > _MATRIX_RTOL * size:
            relation = "-v . A u" if sign < 0 else "v . A u"
            raise ValueError(
                f"`{name}` must {rule}; at x = {shown(x)} the random probe #{k} gives u . A v = {u @ Av!r} but "
                f"{relation} = {sign * (v @ Au)!r} (terms of size {size:.3g}). Pass check=False to skip this check."
            )
        if direction is not None:
            form = float(v @ Av)
            if -direction * form > _SIGN_RTOL * np.linalg.norm(v) * np.linalg.norm(Av):
                kind, effect = ("negative", "S would rise") if direction < 0 else ("positive", "the entropy would fall")
                raise ValueError(
                    f"`{name}` must be {kind} semidefinite (a metric of the wrong sign: {effect}); at x = {shown(x)} "
                    f"the random probe #{k} gives v . A v = {form!r}. Pass check=False to skip this check."
                )


def _require_null_action(name, x, apply, v, rule, n):
    """``A v = 0`` for an action, to 1e-5 of ``|A|_est |v|`` (``|A|_est``: the largest ``|A u| / |u|`` over
    random probes u)."""
    rng = np.random.default_rng([20261124, n])
    estimate = max(np.linalg.norm(apply(u)) / np.linalg.norm(u) for u in rng.normal(size=(_PROBES, n)))
    residual = np.abs(apply(v))
    size = estimate * np.linalg.norm(v)
    if np.linalg.norm(residual) > 1e-5 * (size + 1e-8):
        raise ValueError(
            f"`{name}` must {rule}; at x = {shown(x)} the product has |entry| up to {residual.max()!r} (at index "
            f"{int(np.argmax(residual))}; |A| |v| ~ {size:.3g}). Pass check=False to skip this check."
        )


def _unit_directions(n):
    d = np.random.default_rng([20261122, n]).normal(size=(_DIRECTIONS, n))
    return d / np.linalg.norm(d, axis=1)[:, None]


def _require_matrix(name, x, A, sign, rule):
    """``A = sign A^T`` to ``_MATRIX_RTOL`` of its largest entry."""
    residual = np.abs(A - sign * A.T).max()
    size = np.abs(A).max()
    if residual > _MATRIX_RTOL * size:
        i, j = np.unravel_index(int(np.argmax(np.abs(A - sign * A.T))), A.shape)
        raise ValueError(
            f"`{name}` must {rule}; at x = {shown(x)} entry [{i}, {j}] is {A[i, j]!r} and [{j}, {i}] is "
            f"{A[j, i]!r} (largest |entry| {size:.3g}). Pass check=False to skip this check."
        )


def _require_null(name, x, A, v, rule):
    """``A v = 0`` to 1e-5 of the size of its terms, ``max_i sum_j |A_ij| |v_j|`` (as the R^3 Casimir check)."""
    residual = np.abs(A @ v)
    size = (np.abs(A) @ np.abs(v)).max()
    if residual.max() > 1e-5 * (size + 1e-8):
        raise ValueError(
            f"`{name}` must {rule}; at x = {shown(x)} the product has |entry| up to {residual.max()!r} "
            f"(at index {int(np.argmax(residual))}; its terms have size {size:.3g}). Pass check=False to skip "
            "this check."
        )


def _require_sign(name, x, A, direction):
    """Fish form (``direction`` -1): A negative semidefinite; GENERIC (+1): positive semidefinite."""
    eigenvalues = np.linalg.eigvalsh(0.5 * (A + A.T))
    size = np.abs(eigenvalues).max() if eigenvalues.size else 0.0
    wrong = eigenvalues.max() if direction < 0 else -eigenvalues.min()
    if wrong > _SIGN_RTOL * size:
        kind, sign, effect = (
            ("negative", ">", "S would rise") if direction < 0 else ("positive", "<", "the entropy would fall")
        )
        value = eigenvalues.max() if direction < 0 else eigenvalues.min()
        raise ValueError(
            f"`{name}` must be {kind} semidefinite (a metric of the wrong sign: {effect}); at x = {shown(x)} it has "
            f"the eigenvalue {value!r} {sign} 0 (largest |eigenvalue| {size:.3g}). Pass check=False to skip this check."
        )
