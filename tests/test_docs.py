"""Documentation: every public name is in the API reference, and the docstring examples run."""

import doctest
import importlib
import importlib.util
import pkgutil
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
