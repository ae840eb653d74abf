"""The methods every experiment compares: geomint's and scipy's.

``geomint_methods`` is the only place that knows geomint's method names.  It
lists the methods the library offers *now* (names absent from ``geomint`` are
skipped), and adds any other exported ``Integrator`` that builds without
arguments, so new methods appear in every figure and table without edits.
"""

from dataclasses import dataclass

import geomint

#: (label, geomint attributes it needs, how to build it from the module)
_CANDIDATES = (
    ("Gonzalez", ("Gonzalez",), lambda g: g.Gonzalez()),
    ("ItohAbe", ("ItohAbe",), lambda g: g.ItohAbe()),
    ("SymmetrizedItohAbe", ("SymmetrizedItohAbe",), lambda g: g.SymmetrizedItohAbe()),
    ("AVF", ("AVF",), lambda g: g.AVF()),
    ("Lie", ("Lie",), lambda g: g.Lie()),
    ("Strang", ("Strang",), lambda g: g.Strang()),
    ("Yoshida4(Gonzalez)", ("Yoshida4", "Gonzalez"), lambda g: g.Yoshida4(g.Gonzalez())),
    ("Yoshida6(Gonzalez)", ("Yoshida6", "Gonzalez"), lambda g: g.Yoshida6(g.Gonzalez())),
    ("Yoshida8(Gonzalez)", ("Yoshida8", "Gonzalez"), lambda g: g.Yoshida8(g.Gonzalez())),
    ("Projected(RK4)", ("Projected", "RK4"), lambda g: g.Projected(g.RK4())),
    ("RK4", ("RK4",), lambda g: g.RK4()),
)

#: geomint methods run with adaptive steps (h=None, rtol = atol) in the work-precision sweeps
_ADAPTIVE = (
    (
        "Projected(DormandPrince853) adaptive",
        ("Projected", "DormandPrince853"),
        lambda g: g.Projected(g.DormandPrince853()),
    ),
    (
        "Projected(DormandPrince54) adaptive",
        ("Projected", "DormandPrince54"),
        lambda g: g.Projected(g.DormandPrince54()),
    ),
    ("Gonzalez adaptive", ("Gonzalez",), lambda g: g.Gonzalez()),
    (
        "Yoshida4(Gonzalez, monotone) adaptive",
        ("Yoshida4", "Gonzalez"),
        lambda g: g.Yoshida4(g.Gonzalez(), monotone=True),
    ),
)

#: scipy.integrate.solve_ivp methods and the relative tolerances of the drift runs
SCIPY_DRIFT = (("RK45", (1e-6, 1e-10)), ("DOP853", (1e-6, 1e-10)), ("LSODA", (1e-6, 1e-10)), ("Radau", (1e-6,)))
#: solve_ivp methods of the work-precision sweeps (each over a range of tolerances)
SCIPY_SWEEP = ("RK45", "DOP853", "Radau", "LSODA")
#: the labels the targets and ratios refer to
BASELINE_RK4 = "RK4"
BASELINE_SCIPY = "DOP853"
GONZALEZ = "Gonzalez"


@dataclass(frozen=True)
class Method:
    """A geomint integrator with the label the figures and tables use."""

    label: str
    integrator: geomint.Integrator

    @property
    def structure_preserving(self):
        """Declared to keep H exactly and S non-increasing at every step."""
        return bool(getattr(self.integrator, "energy_exact", False) and getattr(self.integrator, "dissipative", False))

    @property
    def single_step(self):
        """One discrete-gradient or Runge-Kutta step per step (not a composition, splitting or wrapper)."""
        return "(" not in self.label and self.label not in ("Lie", "Strang")

    @property
    def order(self):
        return getattr(self.integrator, "order", None)


def adaptive_methods(module=geomint):
    """The geomint methods the work-precision sweeps also run with adaptive steps."""
    return [
        Method(label, build(module))
        for label, needs, build in _ADAPTIVE
        if all(hasattr(module, name) for name in needs)
    ]


def geomint_methods(module=geomint, skipped=None):
    """Every geomint method available in ``module``, as ``Method`` objects.

    Candidates whose names ``module`` lacks are left out; a candidate whose
    constructor rejects the call is left out and its error appended to
    ``skipped`` (a list) when given.  Exported ``Integrator`` subclasses not
    listed above, integrating the whole field and buildable without arguments
    are appended under their class name.
    """
    methods = []
    for label, needs, build in _CANDIDATES:
        if not all(hasattr(module, name) for name in needs):
            continue
        try:
            methods.append(Method(label, build(module)))
        except (TypeError, ValueError) as error:
            if skipped is not None:
                skipped.append(f"{label}: {error}")
    known = {type(m.integrator) for m in methods}
    for name in getattr(module, "__all__", ()):
        cls = getattr(module, name)
        if not (isinstance(cls, type) and issubclass(cls, module.Integrator)) or cls is module.Integrator:
            continue
        if cls in known:
            continue
        try:
            integrator = cls()
        except (TypeError, ValueError):
            continue
        if integrator.whole_field:  # sub-flow integrators are parts of splittings only
            methods.append(Method(name, integrator))
    return methods
