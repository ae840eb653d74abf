"""The catalogue: the paper's systems and a non-quadratic one; and systems in R^n.

Every entry is built with a public constructor (``MetriplecticSystem``, in R^n
``MetriplecticSystemN`` or ``GenericSystem``) from module-level jitted
functions that take their parameters from ``params``, so one cached
compilation serves every parameter choice.

``CATALOGUE`` holds the systems in R^3 (the command line and scenes use it);
``RN_CATALOGUE`` those in R^n, each callable without arguments.
"""

from .degenerate import degenerate_example
from .euler import (
    euler_coefficients,
    euler_galerkin,
    euler_initial_state,
    euler_modes,
    euler_variables,
    euler_vorticity,
    euler_zeitlin,
)
from .gas_containers import gas_containers, gas_containers_limit
from .heat_bath import heat_bath_closed_form, heat_bath_oscillator
from .oscillator import dissipative_oscillator
from .pendula import damped_pendula
from .random_fish import random_fish
from .rigid_body import quartic_rigid_body, relaxing_rigid_body

CATALOGUE = {
    "relaxing_rigid_body": relaxing_rigid_body,
    "quartic_rigid_body": quartic_rigid_body,
    "dissipative_oscillator": dissipative_oscillator,
    "degenerate_example": degenerate_example,
}

RN_CATALOGUE = {
    "random_fish": random_fish,
    "euler_zeitlin": euler_zeitlin,
    "euler_galerkin": euler_galerkin,
    "damped_pendula": damped_pendula,
    "gas_containers": gas_containers,
    "heat_bath_oscillator": heat_bath_oscillator,
}

__all__ = [
    "CATALOGUE",
    "RN_CATALOGUE",
    "damped_pendula",
    "degenerate_example",
    "dissipative_oscillator",
    "euler_coefficients",
    "euler_galerkin",
    "euler_initial_state",
    "euler_modes",
    "euler_variables",
    "euler_variables",
    "euler_vorticity",
    "euler_zeitlin",
    "gas_containers",
    "gas_containers_limit",
    "heat_bath_closed_form",
    "heat_bath_oscillator",
    "quartic_rigid_body",
    "random_fish",
    "relaxing_rigid_body",
]
