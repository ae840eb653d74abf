"""Experiments that regenerate every figure and table in ``docs/``.

Run everything with ``python -m experiments.all [--quick]``; the per-step
benchmark alone with ``python -m experiments.benchmark [--quick]``.  Only the
public geomint API is used; ``methods.geomint_methods`` is the one place that
knows method names, so methods added to the library appear without edits here.
"""
