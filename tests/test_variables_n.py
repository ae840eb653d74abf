"""The names of the coordinates of a system (``system.variables``): defaults, validation naming ``variables``, and
the catalogue's names."""

import numpy as np
import pytest
from test_systems_n import _H, _P, _S, _grad_H, _grad_S  # the small Fish system in R^4

import geomint
from geomint import systems


def _system(**kwargs):
    return geomint.MetriplecticSystem(H=_H, grad_H=_grad_H, S=_S, grad_S=_grad_S, P=_P, dim=4, **kwargs)


def test_defaults_and_names_given():
    assert _system().variables == ("x0", "x1", "x2", "x3")
    assert _system(variables=["q", "p", "u", "s"]).variables == ("q", "p", "u", "s")
    assert geomint.systems.relaxing_rigid_body().variables == ("x", "y", "z")
    assert _system(variables=("a", "b", "c", "d")).with_effects(eps=0.5).variables == ("a", "b", "c", "d")


@pytest.mark.parametrize(
    "variables, error, match",
    [
        ("qpus", TypeError, r"`variables` must be a sequence of n = 4 distinct names .*; got 'qpus'"),
        (3, TypeError, r"`variables` must be a sequence of n = 4"),
        (("q", "p", "u"), ValueError, r"`variables` must be a sequence of n = 4 .*; got 3 names"),
        (("q", "p", "q", "s"), ValueError, r"`variables` .*; 'q' is given 2 times"),
        (("q", "p", "2u", "s"), ValueError, r"`variables` .*; '2u' is not an identifier"),
        (("q", "p", "lambda", "s"), ValueError, r"`variables` .*; 'lambda' is not an identifier"),
        (("q", "p", 1, "s"), ValueError, r"`variables` .*; 1 is not an identifier"),
    ],
)
def test_bad_names_are_refused_naming_variables(variables, error, match):
    with pytest.raises(error, match=match):
        _system(variables=variables)


def test_the_catalogue_names_its_coordinates():
    assert systems.damped_pendula(2).variables == ("q1", "q2", "p1", "p2", "s")
    assert systems.gas_containers().variables == ("q", "p", "S1", "S2")
    assert systems.heat_bath_oscillator().variables == ("q", "p", "s")
    assert systems.random_fish(3).variables == ("x0", "x1", "x2")
    names = systems.euler_zeitlin(5).variables
    assert len(names) == 24 and names == systems.euler_galerkin(5).variables == systems.euler_variables(5)
    modes = systems.euler_modes(5)
    i = int(np.flatnonzero((modes[:, 0] == 1) & (modes[:, 1] == -2))[0])
    assert names[2 * i : 2 * i + 2] == ("re_1_m2", "im_1_m2") and names[:2] == ("re_0_1", "im_0_1")
    for name in systems.RN_CATALOGUE:
        system = systems.RN_CATALOGUE[name]()
        assert len(system.variables) == system.dim == len(set(system.variables))
