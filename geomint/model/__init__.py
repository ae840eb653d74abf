"""What the equation is: one concept per module.

* ``system``: ``MetriplecticSystem``, the model and its evaluation;
* ``system_n``: ``MetriplecticSystemN`` and ``GenericSystem``, systems in R^n (Fish and GENERIC forms);
* ``functions``: typing and compiling the user's numba functions, handed to kernels as first-class functions;
* ``checks``: the structure checked at sample points (gradients, Casimir, Jacobi, skew P, exact flows; in R^n
  skew P, the Casimir and the user's metric);
* ``axial`` [R3]: ``P v = v x J``, ``curl J`` and the cross-product arithmetic of the fields;
* ``expressions``: systems in R^3 written as formulas; ``expressions_n`` in R^n (named variables, indexed
  families, matrices by rules), its halves ``expressions_variables`` (declarations, no sympy) and
  ``expressions_symbolic`` (parsing, exact derivatives, checks, generated source); ``expressions_cache``: where
  generated modules live and how they are imported.

Importing the package imports ``system_n``, which registers the R^n class with ``MetriplecticSystem`` (so that
``MetriplecticSystem(..., dim=n)`` makes one).
"""

from .system_n import GenericSystem, MetriplecticSystemN

__all__ = ["GenericSystem", "MetriplecticSystemN"]
