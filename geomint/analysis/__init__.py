"""Equilibria on a level set ``{H = H0}``, the proposition that explains each, and their stability.

The paper (D. Fish, *Dissipative perturbations of 3d Hamiltonian systems*,
section 1) relates the zeros of ``xi = xi_P + eps xi_g`` to the geometry of H
and S; this package evaluates those relations, finds the equilibria and
classifies them.  One concept per module:

* ``propositions``: the conditions of Lemmas 6, 8 and Props. 9-11 at many points
  (``conditions``, ``shared_equilibria_hold``, ``regular_equilibria_explained``,
  ``gradient_zeros_explained``) and the proposition that explains a zero (``explain``);
* ``stability``: the tangent-plane Jacobian (``tangent_basis``, ``linearise``),
  its ``verdict`` and ``eigenvalue_kind``; ``factorise`` [R3];
* ``equilibria``: ``equilibria`` (``Equilibrium``, ``EquilibriumCurve``),
  ``equilibrium_points``; ``rest_cycles`` and ``classify_cycle`` [R3];
* ``zero_sets``: least-squares correction onto a zero (``refine``) and curve tracing;
* ``level_set`` [R3]: points on, meshes and plane sections of a level set;
* ``continuation``: equilibria, curves and cycles followed in eps.

Every name below is importable from ``geomint.analysis``.
"""

from . import continuation as continuation  # the submodules users reach by name
from . import level_set as level_set
from ._common import FIELDS
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
from .stability import Factorisation, eigenvalue_kind, factorise, linearise, tangent_basis, verdict
from .zero_sets import refine

__all__ = [
    "FIELDS",
    "REASONS",
    "Conditions",
    "Equilibrium",
    "EquilibriumCurve",
    "Factorisation",
    "RestCycle",
    "classify_cycle",
    "conditions",
    "eigenvalue_kind",
    "equilibria",
    "equilibrium_points",
    "explain",
    "factorise",
    "gradient_zeros_explained",
    "linearise",
    "refine",
    "regular_equilibria_explained",
    "rest_cycles",
    "shared_equilibria_hold",
    "tangent_basis",
    "verdict",
]
