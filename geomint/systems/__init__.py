"""The catalogue: the paper's systems and a non-quadratic one.

Every entry is built with the public constructor ``MetriplecticSystem`` from
module-level jitted functions that take their parameters from ``params``, so
one cached compilation serves every parameter choice.
"""

from .degenerate import degenerate_example
from .oscillator import dissipative_oscillator
from .rigid_body import quartic_rigid_body, relaxing_rigid_body

CATALOGUE = {
    "relaxing_rigid_body": relaxing_rigid_body,
    "quartic_rigid_body": quartic_rigid_body,
    "dissipative_oscillator": dissipative_oscillator,
    "degenerate_example": degenerate_example,
}

__all__ = ["CATALOGUE", "degenerate_example", "dissipative_oscillator", "quartic_rigid_body", "relaxing_rigid_body"]
