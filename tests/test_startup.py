"""Start-up: ``import geomint`` imports no layer and no heavy dependency until a name is used, and every public
name still resolves as before (``geomint/__init__.py``; the times are in docs/startup.md, not asserted here)."""

import os
import pickle
import subprocess
import sys
from pathlib import Path

import geomint

ROOT = Path(__file__).resolve().parents[1]

#: heavy modules a process pays for only when it uses them: scipy (also imported by numba), sympy (systems as
#: formulas), matplotlib (figures), numba and the compiled kernels (a solve), and the optional ones
HEAVY = ("scipy", "sympy", "matplotlib", "numba", "llvmlite", "geomint._kernels", "xarray", "dask", "tqdm")


def _python(code):
    """Run ``code`` in a fresh interpreter that imports this checkout's geomint; its stdout."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, env=env)
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_importing_geomint_loads_no_heavy_module():
    loaded = _python(
        f"import sys, geomint; print(geomint.__file__); print(*[m for m in {HEAVY!r} if m in sys.modules])"
    ).splitlines()
    assert Path(loaded[0]).parent == ROOT / "geomint"
    assert loaded[1:] in ([], [""]), f"import geomint loaded {loaded[1]}"


def test_every_public_name_resolves_in_a_fresh_process():
    """Each name of ``__all__`` (and the layers ``integrators``, ``model``, ``results``, ``run``, ``scene``) is
    there, is listed by ``dir`` (tab completion), comes by ``from geomint import *``, and is the object its layer
    defines."""
    code = """
import geomint
names = sorted(set(geomint.__all__) | {"integrators", "model", "results", "run", "scene"})
missing = [n for n in names if n not in dir(geomint)]
values = {n: getattr(geomint, n) for n in names}
namespace = {}
exec("from geomint import *", namespace)
starred = sorted(n for n in geomint.__all__ if namespace.get(n) is not values[n])
from geomint.run.solve import solve
from geomint.integrators.discrete_gradient import Gonzalez
from geomint.run import events
from geomint.analysis import continuation
same = (geomint.solve is solve, geomint.Gonzalez is Gonzalez, geomint.events is events,
        geomint.continuation is continuation, geomint.__version__ == geomint._version.__version__)
print(missing, starred, all(same), len(names))
"""
    assert _python(code).split() == ["[]", "[]", "True", str(len(set(geomint.__all__)) + 5)]


def test_earlier_names_stay_importable():
    """Modules that moved into a layer import under their earlier names as the same module, and the names that
    moved to ``studies`` are reachable where they were."""
    code = """
import sys
import geomint.events, geomint.continuation, geomint.level_set, geomint.reference
from geomint.run import events
from geomint.analysis import continuation, level_set
from geomint.systems import reference
from geomint.integrators import S_rise_statistics
from geomint.diagnostics import Curve, measured_order, reference_solution, work_precision
from geomint import studies
print(sys.modules["geomint.events"] is events, geomint.continuation is continuation,
      sys.modules["geomint.level_set"] is level_set, geomint.reference is reference,
      events.__spec__.name == "geomint.run.events", S_rise_statistics is studies.S_rise_statistics,
      work_precision is studies.work_precision, Curve is studies.Curve, "S_rise_statistics" in dir(geomint.integrators))
"""
    assert set(_python(code).split()) == {"True"}


def test_a_system_pickled_here_loads_in_a_fresh_process():
    """A system sent to another process (an ensemble's workers, a multiprocessing pool) is rebuilt there from
    its modules, with nothing of ``geomint`` imported beforehand."""
    system = geomint.systems.relaxing_rigid_body(0.5, 1.0, 1.5, eps=0.1)
    data = pickle.dumps(system)
    code = f"""
import pickle, sys
system = pickle.loads({data!r})
print(type(system).__module__, type(system).__name__, system.H([1.0, 0.0, 0.0]))
"""
    assert _python(code).split() == ["geomint.model.system", "MetriplecticSystem", repr(system.H([1.0, 0.0, 0.0]))]
