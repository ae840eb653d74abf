"""The rules of the house, read from the sources (ast): the import graph of the package has no circle, and no
layer imports one it must not.  A failure names the offending import (file and line).

The layers (geomint/__init__.py's docstring): ``_kernels`` computes steps; ``model`` says what the equation
is; ``integrators`` what a method is; ``results`` what comes back; ``run`` how a run is driven; ``scene``,
``plotting`` and ``cli`` are the face.  Modules marked ``[R3]`` in the first line of their docstring hold
what is three-dimensional by nature and stand at the leaves.
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "geomint"


def _name(path):
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _imports(name, path, top_level_only=False):
    """``(target module, line)`` for every import in ``path``, at module level or (unless ``top_level_only``)
    inside a function."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text(), str(path))
    for node in tree.body if top_level_only else ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("geomint"):
                    yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                source = ".".join(base + ([node.module] if node.module else []))
            elif node.module and node.module.startswith("geomint"):
                source = node.module
            else:
                continue
            for alias in node.names:
                submodule = f"{source}.{alias.name}"
                yield (submodule if submodule in MODULES else source), node.lineno


EDGES = {
    name: [(t, line) for t, line in _imports(name, path) if t in MODULES and t != name]
    for name, path in MODULES.items()
}
#: the imports that run when a module is imported (not those inside functions, run on first use)
LOADED = {
    name: [(t, line) for t, line in _imports(name, path, True) if t in MODULES and t != name]
    for name, path in MODULES.items()
}


def _r3(name):
    doc = ast.get_docstring(ast.parse(MODULES[name].read_text())) or ""
    return "[R3]" in doc.splitlines()[0] if doc else False


def _within(name, *layers):
    return any(name == f"geomint.{layer}" or name.startswith(f"geomint.{layer}.") for layer in layers)


def _offences(allowed, edges=EDGES):
    return [
        f"{MODULES[a].relative_to(PACKAGE.parent)}:{line} imports {b}"
        for a, targets in edges.items()
        for b, line in targets
        if not allowed(a, b)
    ]


def test_no_import_circle_between_modules():
    """Tarjan's strongly connected components; a package's ``__init__`` counts as a module of its own."""
    index, low, stack, on_stack, circles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w, _ in EDGES[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in MODULES:
        if v not in index:
            visit(v)
    where = [
        [f"{MODULES[a].relative_to(PACKAGE.parent)}:{line} imports {b}" for a in c for b, line in EDGES[a] if b in c]
        for c in circles
    ]
    assert not circles, f"import circles: {where}"


@pytest.mark.parametrize(
    ("rule", "allowed"),
    [
        ("results never import the run layer", lambda a, b: not (_within(a, "results") and _within(b, "run"))),
        (
            "the face (cli, scene, plotting) never imports _kernels",
            lambda a, b: not (_within(a, "cli", "scene", "plotting") and _within(b, "_kernels")),
        ),
        ("integrators/ never imports the model", lambda a, b: not (_within(a, "integrators") and _within(b, "model"))),
    ],
    ids=lambda value: value if isinstance(value, str) else "",
)
def test_layers_import_only_what_they_may(rule, allowed):
    offences = _offences(allowed)
    assert not offences, f"{rule}: {offences}"


def test_importing_the_core_loads_no_three_dimensional_module():
    """model/, run/ and results/ load no [R3] module when imported; the R^3 forms (an axial J) load theirs on
    first use, so that the R^n engine can stand beside them."""
    offences = _offences(lambda a, b: not (_within(a, "model", "run", "results") and not _r3(a) and _r3(b)), LOADED)
    assert not offences, offences
    assert any(_r3(name) for name in MODULES), "no module is marked [R3]: the check above could not fail"


def test_the_graph_is_read():
    """The checks above see the package: modules and imports are found (else they could not fail)."""
    assert len(MODULES) > 40 and sum(map(len, EDGES.values())) > 100
    assert ("geomint.run.solve", 0) not in EDGES["geomint"] and any(
        t == "geomint.run.solve" for t, _ in EDGES["geomint"]
    )
