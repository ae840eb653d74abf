"""``Status``: how a run ended, every outcome with its message and what to do about it.

The codes are the compiled kernels' plain integers (``geomint._kernels.layout``, where they are defined);
``Status`` names them for users, as ``scipy``'s ``status``, diffrax's ``RESULTS`` and heyoka's
``taylor_outcome`` do.  ``Solution.status`` and an ensemble's ``status`` hold these values (an ``IntEnum`` is an
``int``: ``sol.status == 0`` still reads as before).

>>> import geomint
>>> geomint.Status(-6).name, geomint.Status.STEP_TOO_SMALL.failed
('STEP_TOO_SMALL', True)
"""

from __future__ import annotations

from enum import IntEnum

from .._kernels import layout as _layout


class Status(IntEnum):
    """The outcome of a run (or of one trajectory of an ensemble); ``message`` says what happened and
    ``advice`` what to do about it.  Negative values are failures: the states up to the failure are kept."""

    OK = _layout.OK
    TERMINATED = _layout.TERMINATED
    INTERRUPTED = _layout.INTERRUPTED
    NOT_RUN = _layout.NOT_RUN
    NEWTON_FAILED = _layout.NEWTON_FAILED
    NON_FINITE = _layout.NON_FINITE
    PROJECTION_FAILED = _layout.PROJECTION_FAILED
    USER_RAISED = _layout.USER_RAISED
    INVALID_START = _layout.INVALID_START
    STEP_TOO_SMALL = _layout.STEP_TOO_SMALL
    NOT_ACCEPTED = _layout.NOT_ACCEPTED

    @property
    def message(self) -> str:
        """What happened, as a sentence fragment."""
        return _MESSAGES[self]

    @property
    def advice(self) -> str:
        """What to do about it ('' where nothing need be done)."""
        return _ADVICE[self]

    @property
    def success(self) -> bool:
        """Whether the run reached its end: ``t_end``, or a terminal event."""
        return self in (Status.OK, Status.TERMINATED)

    @property
    def failed(self) -> bool:
        """Whether a step failed (a negative code)."""
        return self < 0


#: each code's ``Status`` by a dict lookup (``Status(code)`` goes through the enum's call machinery, a tenth of a
#: microsecond per code read, several per short ``solve``)
BY_CODE = {int(status): status for status in Status}

_MESSAGES = {
    Status.OK: "the integration reached t_end",
    Status.TERMINATED: "a terminal event stopped the run",
    Status.INTERRUPTED: "interrupted (SIGINT); the states computed so far are kept",
    Status.NOT_RUN: "not run: the ensemble was interrupted (SIGINT) before this trajectory started",
    Status.NEWTON_FAILED: "the Newton iteration did not converge",
    Status.NON_FINITE: "a non-finite value appeared",
    Status.PROJECTION_FAILED: "the projection found no point of H = H0 that does not raise S",
    Status.USER_RAISED: "a user function raised inside a step",
    Status.INVALID_START: "invalid start: H or S is not finite there",
    Status.STEP_TOO_SMALL: "the error control needed a step below the resolution of t (16 ulp)",
    Status.NOT_ACCEPTED: "the solve converged to a state that failed the acceptance even after the level "
    f"corrections (H within {_layout.ACCEPT_ULPS:g} ulps of its terms of H0, S not against its direction by more "
    f"than {_layout.ACCEPT_S_ULPS:g})",
}
_ADVICE = {
    Status.OK: "",
    Status.TERMINATED: "",
    Status.INTERRUPTED: "Run again (a checkpointed fixed-step run resumes with `resume`).",
    Status.NOT_RUN: "Run the ensemble again.",
    Status.NEWTON_FAILED: "A smaller step `h` usually helps; DampedGonzalez() where h eps |grad H|^2 is large.",
    Status.NON_FINITE: "Check that the system is defined along the trajectory.",
    Status.PROJECTION_FAILED: "A smaller step `h` keeps the projection's move small.",
    Status.USER_RAISED: "Return NaN where a function is undefined (the step then fails as non-finite), or keep the "
    "trajectory inside its domain.",
    Status.INVALID_START: "Start where H and S are finite.",
    Status.STEP_TOO_SMALL: "Loosen rtol/atol; if the solution is stiff there, DampedGonzalez() takes steps "
    "limited by accuracy only.",
    Status.NOT_ACCEPTED: "H or S carries more round-off there than the size of its terms shows (terms that cancel, "
    "a noisy evaluation); an adaptive run (rtol) retries smaller steps. If H and S are smooth, please report the "
    "system: the level search should leave no such miss.",
}
