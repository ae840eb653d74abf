"""Every integer code, array layout, constant and named tuple the kernels and ``geomint.run`` share.

One module, imported by all the others and importing none of them, so the
kernels have no import cycle.  The outcome codes are defined here and only
here; ``geomint.Status`` (``geomint/run/status.py``) gives each its name,
message and advice.

Step data (a lowered method).  An integrator lowers itself
(``Integrator.lower(system)``) to one of the named tuples below; their *class*
selects the compiled step at typing time (``step.step``), so a run compiles
only the family it uses: a Gonzalez run compiles neither compositions nor the
other discrete gradients.
"""

from collections import namedtuple

import numpy as np

#: the unit round-off of float64, and its square root (difference quotients)
EPS = float(np.finfo(np.float64).eps)
SQRT_EPS = float(np.sqrt(EPS))

# -- outcome codes of a run (``geomint.Status``: names, messages, advice) ------------------------------
OK = 0
TERMINATED = 1  # a terminal event stopped the run (as scipy's 1)
INTERRUPTED = 2  # Ctrl-C, answered between chunks of the loop
NOT_RUN = 3  # an ensemble's trajectory not started before Ctrl-C
NEWTON_FAILED = -1
NON_FINITE = -2
PROJECTION_FAILED = -3
USER_RAISED = -4  # a user function raised inside the step (``geomint._user_errors``)
INVALID_START = -5  # an ensemble's start where H or S is not finite
STEP_TOO_SMALL = -6  # an adaptive run needed a step below the resolution of its time
NOT_ACCEPTED = -7  # an R^n step whose solve converged missed the acceptance (H, S beyond round-off)

# -- the acceptance of a step (R^3 ``newton``, R^n ``step_n``) -----------------------------------
#: an accepted step keeps H to its anchor within this many ulps of its terms: twice the bound below which the
#: discrete-gradient correction is round-off and skipped (``discrete_gradient.gonzalez``)
ACCEPT_ULPS = 4.0
#: and does not move S against its direction by more than this many ulps of its terms
ACCEPT_S_ULPS = 2.0

# -- which user function produced a non-finite value (counters[CULPRIT]) ------------------------
UNKNOWN = 0
FN_H = 1
FN_GRAD_H = 2
FN_S = 3
FN_GRAD_S = 4
FN_POISSON = 5
FUNCTION_NAMES = {UNKNOWN: None, FN_H: "H", FN_GRAD_H: "grad_H", FN_S: "S", FN_GRAD_S: "grad_S", FN_POISSON: "J/P"}

# -- counters (int64 array shared by loop.run and geomint.run) --------------------------
STEPS = 0
NEWTON_ITERATIONS = 1
FIELD_EVALUATIONS = 2
STATUS = 3
FAILED_STEP = 4
ROWS = 5
CULPRIT = 6
RAISED = 7  # exceptions user functions raised, counted by ``geomint._user_errors``
REJECTED = 8  # attempted steps an adaptive run rejected (error above tolerance, or a failed attempt retried)
N_COUNTERS = 9
#: S-rise counts of a ``control.Counting`` run, after the counters above: sub-steps that raised S, full steps that
#: raised S (after the safeguard), full steps the monotone safeguard redid
SUB_STEP_RISES = 9
FULL_STEP_RISES = 10
SAFEGUARD_FIRED = 11
N_RISE_COUNTERS = 12

# -- run state (float64 array carried from chunk to chunk) -------------------------------------
#    x (3), its compensation (3), the energy anchor H(x0), S(x_n)
STATE_X = 0
STATE_COMP = 3
STATE_ANCHOR = 6
STATE_S = 7
N_STATE = 8

# -- clock of a run (float64 array carried from chunk to chunk, ``loop.run``, ``control``)
#    the time of the state, the next step to try (signed), the last accepted error norm (PI controller),
#    fixed steps: the time of the last landing and the steps taken since (a ``Constant`` grid: since t0);
#    the index of the next stop; the reach of the energy anchor (``control`` module docstring)
C_T = 0
C_H = 1
C_ERROR = 2
C_BASE = 3
C_COUNT = 4
C_STOP = 5
C_REACH = 6
N_CLOCK = 7


def new_clock(t0, h=0.0, steps=0):
    """A clock at ``t0`` whose next step is ``h`` (0: chosen by ``control.first_step``), full reach, ``steps``
    steps taken (a ``control.Constant`` grid resumed: ``t0`` is then ``t0 + steps h``)."""
    clock = np.zeros(N_CLOCK)
    clock[C_T] = clock[C_BASE] = t0
    clock[C_H] = h
    clock[C_COUNT] = steps
    clock[C_REACH] = 1.0
    return clock


# -- error estimators of an adaptive run (``control.Control.estimator``)
NO_ESTIMATE = 0  # fixed steps that land on the stops
EMBEDDED = 1  # the method's own embedded pair (``EmbeddedPairStep``)
RK4_REFERENCE = 2  # a discrete-gradient step against the explicit RK4 step from the same state
DOUBLING = 3  # one step of h against two of h/2 (Richardson), for any method

# -- per-slot workspace of an implicit step (float64), one slot per sub-step position --------------
#    the last three accepted increments (predictor), the step they were taken with, how many are
#    valid, and the Jacobian D xi(x) of the field the slot integrates (simplified Newton)
W_DX1 = 0
W_DX2 = 3
W_DX3 = 6
W_H = 9
W_HISTORY = 10
W_JACOBIAN = 11
W_JACOBIAN_VALID = 20
WORK = 21

# -- flows a stage integrates --------------------------------------------------------------------
FULL = 0
HAMILTONIAN = 1
GRADIENT = 2

# -- discrete gradients --------------------------------------------------------------------------
GONZALEZ = 0
ITOH_ABE = 1
SYMMETRIZED_ITOH_ABE = 2
AVF = 3

# -- leaves of a composed program ----------------------------------------------------------------
LEAF_RK4 = 0
LEAF_DISCRETE_GRADIENT = 1
LEAF_RIGID_BODY_FLOW = 2
LEAF_ROTOR_SPLITTING = 3
LEAF_ROTATION = 4

# -- projections ---------------------------------------------------------------------------------
NO_PROJECTION = 0
STANDARD = 1
SYMMETRIC = 2

# -- composed program layout (iopts) -------------------------------------------------------------
#    header, then one row per stage (and the safeguard's fallback leaf last):
#    leaf code, flow, discrete-gradient kind, max_iter, damped, compensated, first coefficient, count
P_GAMMAS = 0
P_STAGES = 1
P_MONOTONE = 2
P_PROJECTION = 3
P_MAX_ITER = 4
P_ANCHOR = 5
HEADER = 6
R_LEAF = 0
R_FLOW = 1
R_KIND = 2
R_MAX_ITER = 3
R_DAMPED = 4
R_COMPENSATED = 5
R_COEFF_AT = 6
R_COEFF_COUNT = 7
ROW = 8

# -- results and step data -------------------------------------------------------------------------
StepResult = namedtuple("StepResult", "x comp H S status iterations evaluations residual culprit")

#: the classical Runge-Kutta method (no data)
RungeKutta4 = namedtuple("RungeKutta4", "stages")

#: the metriplectic discrete-gradient step; ``kind`` is one of the kind markers below, ``damped`` one of the
#: damping markers (its type decides at compile time, so an undamped run does not compile the damping factor)
DiscreteGradientStep = namedtuple("DiscreteGradientStep", "kind max_iter damped compensated coeffs")
Damped = namedtuple("Damped", "on")
Undamped = namedtuple("Undamped", "on")
GonzalezKind = namedtuple("GonzalezKind", "code")
ItohAbeKind = namedtuple("ItohAbeKind", "code")
SymmetrizedItohAbeKind = namedtuple("SymmetrizedItohAbeKind", "code")
AVFKind = namedtuple("AVFKind", "code")
KIND_MARKERS = {
    GONZALEZ: GonzalezKind,
    ITOH_ABE: ItohAbeKind,
    SYMMETRIZED_ITOH_ABE: SymmetrizedItohAbeKind,
    AVF: AVFKind,
}

#: an explicit Runge-Kutta pair: ``b`` the propagating weights (the nodes are not needed, the field is
#: autonomous), its error weights ``e`` (over the stages and xi at the new state, as in FSAL pairs) and, for
#: Dormand-Prince 8(5,3), ``e_low`` (zero-size otherwise); ``projection`` is ``NO_PROJECTION`` or ``STANDARD``; the
#: stages live in ``slots`` workspace slots.  The strictly lower triangular ``a`` is given by its nonzero entries
#: row by row (row i: columns ``a_cols[a_starts[i]:a_starts[i + 1]]``, j increasing, values ``a_values`` alike), so
#: the stages skip its zeros without testing each entry
EmbeddedPairStep = namedtuple("EmbeddedPairStep", "b e e_low projection max_iter slots a_starts a_cols a_values")

#: splittings, compositions and projections: a flat program (``composition``); ``uses`` is a tuple of
#: markers, one for each leaf the program can run (a discrete-gradient leaf by its kind marker above, the others
#: by ``LEAF_MARKERS``) and ``Damped(True)`` if a stage is damped: their types decide what
#: ``composition.leaf_step`` compiles, so a Yoshida4(Gonzalez()) run compiles neither RK4 nor the exact flows
ComposedStep = namedtuple("ComposedStep", "coeffs iopts slots uses")
RK4Leaf = namedtuple("RK4Leaf", "code")
RigidBodyFlowLeaf = namedtuple("RigidBodyFlowLeaf", "code")
RotorSplittingLeaf = namedtuple("RotorSplittingLeaf", "code")
RotationLeaf = namedtuple("RotationLeaf", "code")
LEAF_MARKERS = {
    LEAF_RK4: RK4Leaf,
    LEAF_RIGID_BODY_FLOW: RigidBodyFlowLeaf,
    LEAF_ROTOR_SPLITTING: RotorSplittingLeaf,
    LEAF_ROTATION: RotationLeaf,
}

#: the model as every kernel receives it: the user's functions (compiled, first-class), params, and
#: ``origin = (H(0), grad H(0), S(0), grad S(0))`` (8 floats, 0 where not finite), from which the
#: kernels measure the constant and linear terms of H and S (``roundoff.origin_terms``)
Model = namedtuple("Model", "H grad_H S grad_S J params origin")

#: a system in R^n (n = len(x)) as the kernels receive it.  First-class user functions of ``(x, params)``, ``x`` a
#: contiguous float64 array of length n: ``H``, ``S`` -> float; ``grad_H``, ``grad_S`` -> (n,) arrays; ``P`` ->
#: (n, n) skew matrix (GENERIC's L); ``M`` -> (n, n) symmetric matrix that replaces the paper's metric g where
#: ``metric`` is ``USER_METRIC`` (Fish form: the user's G, negative semidefinite, G grad H = 0; GENERIC: the
#: friction matrix, positive semidefinite, M grad E = 0), never called where it is ``PAPER_METRIC``.  The field is
#: ``P grad H + eps D grad S`` with D = g or M; ``direction`` is -1.0 where S never rises (Fish), +1.0 where it
#: never falls (GENERIC, eps = 1).  ``origin`` holds H(0), S(0) (0 where not finite): the constant terms.
#: ``P_apply``, ``M_apply``: the same operators as actions ``(x, v, params) -> P(x) v`` (length-n arrays);
#: ``actions`` says which form each operator is native in (``P_ACTION``, ``M_ACTION`` bits): the kernels call
#: the action where its bit is set and the matrix otherwise.  The unused form of each is a placeholder of the
#: same type (never called), so that every system in R^n has one numba type.
ModelN = namedtuple("ModelN", "H grad_H S grad_S P M params metric direction origin P_apply M_apply actions")
PAPER_METRIC = 0
USER_METRIC = 1
#: bits of ``ModelN.actions``: P (GENERIC's L) given as an action, the metric (G, GENERIC's M) given as an action
P_ACTION = 1
M_ACTION = 2
