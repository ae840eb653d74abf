"""What the equation is: one concept per module.

* ``system``: ``MetriplecticSystem``, the model and its evaluation;
* ``functions``: typing and compiling the user's numba functions, handed to kernels as first-class functions;
* ``checks``: the structure checked at sample points (gradients, Casimir, Jacobi, skew P, exact flows);
* ``axial`` [R3]: ``P v = v x J``, ``curl J`` and the cross-product arithmetic of the fields;
* ``expressions``: systems written as formulas.
"""
