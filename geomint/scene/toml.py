"""Scene files in both directions: reading a file's text into its sections (``tomllib``: nothing in it is
evaluated as Python), writing sections back as TOML, and finding a scene by path or by the name of a bundled
one (``geomint/scenes/*.toml`` in R^3 and ``geomint/scenes/rn/*.toml`` in R^n, package data)."""

from __future__ import annotations

import json
import os
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .checks import SceneError, _listing

if TYPE_CHECKING:
    import os
    from importlib.resources.abc import Traversable


def read_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The sections of the scene file ``path`` as a dict; an unreadable or malformed file raises ``SceneError``
    naming it."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SceneError(str(path), None, f"cannot read the scene file ({exc.strerror}).") from None
    except UnicodeDecodeError as exc:
        raise SceneError(
            str(path),
            None,
            f"not UTF-8 text (byte {exc.object[exc.start]:#04x} at position {exc.start}); save the file as UTF-8.",
        ) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(str(path), None, f"not valid TOML: {exc}.") from None
    except RecursionError:
        raise SceneError(
            str(path), None, "tables or arrays nested too deeply to read; a scene needs two levels."
        ) from None


def to_toml(data: dict[str, Any]) -> str:
    """TOML text for a scene's ``to_dict()`` (top-level keys, then one table per section)."""
    top = [f"{key} = {toml_value(value)}" for key, value in data.items() if not isinstance(value, dict)]
    tables = [
        f"\n[{key}]\n" + "\n".join(f"{k} = {toml_value(v)}" for k, v in value.items())
        for key, value in data.items()
        if isinstance(value, dict)
    ]
    return "\n".join(top) + "\n" + "\n".join(tables)


def toml_value(value: Any) -> str:
    """One value (a plain one: ``plain``) as TOML text."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    return "[" + ", ".join(toml_value(v) for v in value) + "]"


def plain(value: Any) -> Any:
    """A value TOML and JSON can hold: tuples and arrays become lists."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (tuple, list, np.ndarray)):
        return [plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def bundled_scenes(rn: bool = False) -> dict[str, Traversable]:
    """Names of the scenes shipped with geomint -> their paths: the paper's examples in R^3, or with ``rn=True``
    the scenes of systems in R^n (``geomint/scenes/rn``)."""
    from importlib import resources

    folder = resources.files("geomint") / "scenes"
    if rn:
        folder = folder / "rn"
    return {
        p.name[:-5]: p
        for p in sorted(folder.iterdir(), key=lambda p: p.name)
        if p.name.endswith(".toml") and p.is_file()
    }


def scene_file(scene: str) -> Path | Traversable:
    """The file of ``scene``: a file path, or the name of a bundled scene (with or without ``.toml``)."""
    if not isinstance(scene, (str, os.PathLike)):
        raise TypeError(
            f"`scene` must be a scene file's path or a bundled scene's name (a str); got {scene!r} "
            f"({type(scene).__name__})."
        )
    scene = os.fspath(scene)
    path = Path(scene)
    if path.is_file():
        return path
    if path.is_dir():
        raise SceneError(scene, None, "is a folder; give a scene file (.toml) or the name of a bundled scene.")
    bundled, bundled_n = bundled_scenes(), bundled_scenes(rn=True)
    stem = scene[:-5] if scene.endswith(".toml") else scene
    if stem in bundled:
        return bundled[stem]
    if stem in bundled_n:
        return bundled_n[stem]
    raise SceneError(
        scene,
        None,
        f"no such scene file, nor a bundled scene; bundled: {_listing(bundled)}; in R^n: {_listing(bundled_n)}.",
    )
