"""MkDocs hook: the API page documents every name in ``geomint.__all__``.

``docs/api.md`` holds the marker ``<!-- API REFERENCE -->``; at build time it
is replaced by one mkdocstrings directive per public name (``::: geomint.NAME``),
so a name added to ``__all__`` appears in the reference without editing the
page.  Values that are neither classes, functions nor modules (``__version__``)
are rendered as module attributes, with their value.  ``tests/test_docs.py`` checks the list.
"""

import inspect
import types

MARKER = "<!-- API REFERENCE -->"


def public_names():
    """``geomint.__all__``, as the package declares it."""
    import geomint

    return list(geomint.__all__)


def api_markdown():
    """The markdown that replaces ``MARKER``: classes and functions first, then modules, then values."""
    import geomint

    groups = {"Classes and functions": [], "Modules": [], "Values": []}
    for name in public_names():
        obj = getattr(geomint, name)
        if isinstance(obj, types.ModuleType):
            groups["Modules"].append(f"::: geomint.{name}")
        elif inspect.isclass(obj) or callable(obj):
            groups["Classes and functions"].append(f"::: geomint.{name}")
        else:
            groups["Values"].append(f"::: geomint.{name}\n    options:\n      show_if_no_docstring: true")
    return "\n\n".join(f"## {title}\n\n" + "\n\n".join(blocks) for title, blocks in groups.items() if blocks)


def on_page_markdown(markdown, page, config, files):
    """MkDocs event: expand the marker on the page that has it."""
    return markdown.replace(MARKER, api_markdown()) if MARKER in markdown else markdown
