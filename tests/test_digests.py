"""Results bit for bit as recorded before the package was reshaped (issue 27: behaviour unchanged).

``tests/data/digests.json`` holds, for every integrator on every catalogue and zoo system, the SHA-256 of a
fixed-step run's saved ``t, x, H, S`` and status, and of adaptive runs' accepted steps and states, as computed
by geomint at 0db555e (and 3753d7a, whose kernels and fixed-step paths are those of 0db555e), then regenerated once
for the discrete field's polish taken only where it can move H or S by an ulp (``discrete_field.polish_moves``:
round-off-level changes of the discrete-gradient steps, issue 30).  Regenerate only for a change that is meant to
change results: ``python tests/test_digests.py`` (and say why in the commit).
"""

import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest
import zoo

import geomint

DATA = Path(__file__).resolve().parent / "data" / "digests.json"

#: every method by name, and wrapped ones that exercise the composition, projection and splitting engines
FIXED = [
    "avf",
    "damped_gonzalez",
    "dop853",
    "gonzalez",
    "itoh_abe",
    "kahan_li6",
    "kahan_li8",
    "lie",
    "oscillator_rotation",
    "projected",
    "rigid_body_flow",
    "rk23",
    "rk4",
    "rk45",
    "rotor_splitting",
    "strang",
    "suzuki4",
    "suzuki_umeno8",
    "symmetrized_itoh_abe",
    "yoshida4",
    "yoshida6",
]
WRAPPED = {
    "Yoshida4(AVF())": lambda: geomint.Yoshida4(geomint.AVF()),
    "Yoshida4(Gonzalez(), monotone=True)": lambda: geomint.Yoshida4(geomint.Gonzalez(), monotone=True),
    "Projected(AVF())": lambda: geomint.Projected(geomint.AVF()),
    "Projected(DormandPrince853())": lambda: geomint.Projected(geomint.DormandPrince853()),
    "Strang(Gonzalez(), AVF())": lambda: geomint.Strang(geomint.Gonzalez(), geomint.AVF()),
    "Strang(RigidBodyFlow(), AVF())": lambda: geomint.Strang(geomint.RigidBodyFlow(), geomint.AVF()),
    "Lie(Gonzalez(), DampedGonzalez())": lambda: geomint.Lie(geomint.Gonzalez(), geomint.DampedGonzalez()),
}
ADAPTIVE = [
    "gonzalez",
    "rk45",
    "dop853",
    "projected",
    "Yoshida4(Gonzalez(), monotone=True)",
    "Projected(DormandPrince853())",
]


def _method(name):
    return WRAPPED[name]() if name in WRAPPED else name


def _digest(*arrays):
    digest = hashlib.sha256()
    for array in arrays:
        digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()[:32]


def _cases():
    animals = zoo.everything()
    names = [a.name for a in animals]
    for index, animal in enumerate(animals):
        key = names[index] if names.count(names[index]) == 1 else f"{names[index]}#{index}"
        x0 = animal.box.draw(np.random.default_rng(27), 1)[0]
        yield key, animal, x0, animal.h[1] / 2


def _run(animal, x0, h, name, adaptive):
    try:
        if adaptive:
            sol = geomint.solve(animal.system, x0, (0.0, 40 * h), method=_method(name), rtol=1e-7, atol=1e-9)
        else:
            sol = geomint.solve(animal.system, x0, (0.0, 40 * h), h, method=_method(name))
    except (TypeError, ValueError) as error:
        return f"refused: {type(error).__name__}"
    return _digest(sol.t, sol.x, sol.H, sol.S, np.array([sol.status, sol.n_steps]))


def compute():
    """Every digest, keyed ``system | method | fixed/adaptive``."""
    out = {}
    for key, animal, x0, h in _cases():
        for name in FIXED + list(WRAPPED):
            out[f"{key} | {name} | fixed"] = _run(animal, x0, h, name, False)
        for name in ADAPTIVE:
            out[f"{key} | {name} | adaptive"] = _run(animal, x0, h, name, True)
    return out


@pytest.fixture(scope="module")
def recorded():
    return json.loads(DATA.read_text())


@pytest.mark.filterwarnings("ignore::geomint.AccuracyWarning")
@pytest.mark.parametrize(("key", "animal", "x0", "h"), list(_cases()), ids=[c[0] for c in _cases()])
def test_results_are_bit_for_bit_those_recorded_before_the_reshape(recorded, key, animal, x0, h):
    changed = []
    for name in FIXED + list(WRAPPED):
        entry = f"{key} | {name} | fixed"
        if _run(animal, x0, h, name, False) != recorded[entry]:
            changed.append(entry)
    for name in ADAPTIVE:
        entry = f"{key} | {name} | adaptive"
        if _run(animal, x0, h, name, True) != recorded[entry]:
            changed.append(entry)
    assert not changed, f"{len(changed)} runs changed: {changed}"


if __name__ == "__main__":
    import warnings

    warnings.simplefilter("ignore")
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    DATA.parent.mkdir(exist_ok=True)
    DATA.write_text(json.dumps(compute(), indent=1, sort_keys=True) + "\n")
    print(f"wrote {DATA}")
