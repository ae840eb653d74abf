"""Equilibria on a level set ``{H = H0}``, the proposition that explains each, and their stability; R^3 and R^n.

The paper (D. Fish, *Dissipative perturbations of 3d Hamiltonian systems*,
section 1) relates the zeros of ``xi = xi_P + eps xi_g`` to the geometry of H
and S; this package evaluates those relations, finds the equilibria and
classifies them.  One concept per module:

* ``propositions``: the conditions of Lemmas 6, 8 and Props. 9-11 at many points
  (``conditions``, ``shared_equilibria_hold``, ``regular_equilibria_explained``,
  ``gradient_zeros_explained``) and the proposition that explains a zero (``explain``);
* ``stability``: the tangent-space Jacobian in R^3 and R^n (``tangent_basis``, ``linearise``),
  its ``verdict`` and ``eigenvalue_kind``, ``hessian_type``; ``factorise`` [R3];
* ``critical_points`` (R^n, and R^3): the critical points of S on ``H = H0`` by Newton's method
  (``critical_points``, ``critical_point``, ``CriticalPoint``, ``to_level_set``), their type and stability;
* ``equilibria``: ``equilibria`` (``Equilibrium``, ``EquilibriumCurve``),
  ``equilibrium_points``; ``rest_cycles`` and ``classify_cycle`` [R3];
* ``zero_sets``: least-squares correction onto a zero (``refine``) and curve tracing [R3];
* ``level_set`` [R3]: points on, meshes and plane sections of a level set;
* ``continuation``: equilibria, curves and cycles followed in eps (``continuation`` in R^3,
  ``continuation_n`` for the critical points in R^n).

The functions that sample a level surface, trace curves on it or use cross products
(``equilibria``, ``rest_cycles``, ``refine``, the propositions, ``factorise``,
``continuation``) take systems in R^3 and refuse others, naming the R^n function to use.

Every name below is importable from ``geomint.analysis``.
"""

from . import continuation as continuation  # the submodules users reach by name
from . import level_set as level_set
from ._common import FIELDS
from .critical_points import CriticalPoint, critical_point, critical_points, to_level_set
from .equilibria import (
    Equilibrium,
    EquilibriumCurve,
    RestCycle,
    classify_cycle,
    equilibria,
    equilibrium_points,
    rest_cycles,
)
from .propositions import (
    REASONS,
    Conditions,
    conditions,
    explain,
    gradient_zeros_explained,
    regular_equilibria_explained,
    shared_equilibria_hold,
)
from .stability import (
    Factorisation,
    eigenvalue_kind,
    factorise,
    hessian_type,
    linearise,
    tangent_basis,
    verdict,
)
from .zero_sets import refine

__all__ = [
    "FIELDS",
    "REASONS",
    "Conditions",
    "CriticalPoint",
    "Equilibrium",
    "EquilibriumCurve",
    "Factorisation",
    "RestCycle",
    "classify_cycle",
    "conditions",
    "critical_point",
    "critical_points",
    "eigenvalue_kind",
    "equilibria",
    "equilibrium_points",
    "explain",
    "factorise",
    "gradient_zeros_explained",
    "hessian_type",
    "linearise",
    "refine",
    "regular_equilibria_explained",
    "rest_cycles",
    "shared_equilibria_hold",
    "tangent_basis",
    "to_level_set",
    "verdict",
]
