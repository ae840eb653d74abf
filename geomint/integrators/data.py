"""Integrators as plain data (TOML/JSON) and back: ``method_to_data`` and ``method_from_data``.

An integrator is a frozen dataclass; its data form is ``{"name": short name,
option: value, ...}`` over the fields its constructor takes (options left
at ``None`` are omitted), with
sub-integrators (a composition's ``base``, a splitting's parts, a projection's
``method``) as nested tables, so every method, however nested, has one
data form::

    {"name": "yoshida4", "base": {"name": "avf", "nodes": 3, ...}, "monotone": False}

A short name alone stands for the method with its defaults:
``method_from_data("strang") == Strang()``.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

from .._validate import did_you_mean
from . import INTEGRATORS, Integrator

if TYPE_CHECKING:
    from collections.abc import Mapping


class MethodDataError(ValueError):
    """A method table that names no integrator or a bad option: ``key`` says where, ``problem`` what."""

    def __init__(self, key: str, problem: str) -> None:
        self.key, self.problem = key, problem
        super().__init__(f"`{key}`: {problem}")


def short_names() -> dict[str, type[Integrator]]:
    """Short name -> integrator class, for every method a scene or ``solve`` can name."""
    return dict(sorted(INTEGRATORS.items()))


def options_of(cls: type[Integrator]) -> list[str]:
    """The constructor's options of an integrator class (dataclass fields with ``init=True``)."""
    return [f.name for f in dataclasses.fields(cls) if f.init]  # pyright: ignore[reportArgumentType]  # a dataclass


def method_to_data(method: Integrator) -> dict[str, Any]:
    """The data form of an integrator instance (JSON- and TOML-ready).

    >>> from geomint import Strang, Gonzalez, RK4
    >>> method_to_data(Strang(gradient_part=RK4()))["gradient_part"]
    {'name': 'rk4'}
    """
    if not isinstance(method, Integrator):
        raise TypeError(f"`method` must be a geomint Integrator; got {method!r}.")
    data: dict[str, Any] = {"name": method.name}
    for option in options_of(type(method)):
        value = getattr(method, option)
        if value is not None:  # None means "not set" (AVF's nodes/degree); TOML has no null
            data[option] = method_to_data(value) if isinstance(value, Integrator) else value
    return data


def method_from_data(data: str | Mapping[str, Any], key: str = "method") -> Integrator:
    """The integrator a data form describes; ``key`` names it in errors (``"integrator.method"``).

    ``data`` is a short name or ``{"name": ..., option: value}``; options that
    hold an integrator take a data form themselves.  Raises
    ``MethodDataError`` naming the key, the rule and the fix.

    >>> method_from_data({"name": "yoshida4", "base": "avf"}).base.name
    'avf'
    """
    if isinstance(data, str):
        data = {"name": data}
    if not isinstance(data, dict) or not isinstance(data.get("name"), str):
        raise MethodDataError(key, f"must be a method name or a table {{ name = ..., option = ... }}; got {data!r}.")
    known = short_names()
    name = data["name"]
    if name not in known:
        raise MethodDataError(key, f"unknown integrator {name!r}; known: {', '.join(known)}.")
    cls = known[name]
    options = options_of(cls)
    defaults = cls()
    kwargs = {}
    for option, value in data.items():
        if option == "name":
            continue
        if option not in options:
            raise MethodDataError(
                f"{key}.{option}",
                f"unknown option of {name!r}; it takes "
                f"{', '.join(sorted(options)) or 'none'}"
                f"{did_you_mean(option, options)}",
            )
        nested = isinstance(getattr(defaults, option), Integrator)
        kwargs[option] = method_from_data(value, f"{key}.{option}") if nested else value
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as exc:
        raise MethodDataError(key, str(exc)) from None
