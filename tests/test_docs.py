"""Documentation: every public name is in the API reference, and the docstring examples run."""

import doctest
import importlib
import importlib.util
import pkgutil
import runpy
from pathlib import Path

import pytest

import geomint

ROOT = Path(__file__).resolve().parent.parent


def _hook():
    spec = importlib.util.spec_from_file_location("api_reference", ROOT / "tools" / "api_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_public_name_has_a_directive_in_the_api_page():
    hook = _hook()
    page = (ROOT / "docs" / "api.md").read_text()
    assert hook.MARKER in page
    rendered = hook.on_page_markdown(page, None, None, None)
    assert hook.public_names() == list(geomint.__all__)
    missing = [name for name in geomint.__all__ if f"::: geomint.{name}\n" not in rendered + "\n"]
    assert not missing, f"not in the API page: {missing}"


def test_every_public_name_is_in_the_built_site_if_there_is_one():
    html = ROOT / "site" / "api" / "index.html"
    if not html.exists():
        pytest.skip("no built site (mkdocs build --strict writes site/)")
    text = html.read_text()
    missing = [name for name in geomint.__all__ if f'id="geomint.{name}"' not in text]
    assert not missing, f"not rendered in site/api/index.html: {missing}"


def _public_modules():
    names = ["geomint"]
    for info in pkgutil.walk_packages(geomint.__path__, "geomint."):
        names.append(info.name)
    return sorted(names)


@pytest.mark.parametrize("name", _public_modules())
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} docstring examples failed in {name}"


RUNNABLE_PAGES = [
    "getting-started.md",
    "coming-from-scipy.md",
    "guides/own-system.md",
    "guides/formulas_rn.md",
    "guides/analysis.md",
    "guides/ensembles.md",
    "relaxation.md",
    "../README.md",
]


@pytest.mark.parametrize("page", RUNNABLE_PAGES)
def test_python_examples_on_the_page_run(page, tmp_path, monkeypatch):
    """The page's ```python blocks, run in order as one script (as a reader would paste them)."""
    text = (ROOT / "docs" / page).read_text()
    blocks = [block.split("```", 1)[0] for block in text.split("```python\n")[1:]]
    assert blocks, f"{page} has no python example"
    script = tmp_path / "example.py"  # a real file: numba's cache=True needs one, and writes beside it
    script.write_text("\n".join(blocks))
    monkeypatch.chdir(tmp_path)
    runpy.run_path(str(script), run_name="__docs_example__")
