"""Markdown tables, number formatting, figures and the machine description for ``docs/``."""

import os
import platform
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

DOCS = Path(__file__).resolve().parent.parent / "docs"


def fmt(value, digits=3):
    """A number for a table: ``—`` for None/NaN, general format otherwise."""
    if value is None:
        return "—"
    if isinstance(value, (bool, str)):
        return str(value)
    if isinstance(value, int):
        return f"{value:,}".replace(",", " ")
    if value != value:
        return "—"
    return f"{value:.{digits}g}"


def markdown_table(headers, rows):
    """A GitHub markdown table; cells go through ``fmt``."""
    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    lines += ["| " + " | ".join(fmt(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


def figure(ncols=1, nrows=1, width=5.2, height=3.8):
    """A new figure with a grid of axes (always a flat list)."""
    fig, axes = plt.subplots(nrows, ncols, figsize=(width * ncols, height * nrows), squeeze=False)
    return fig, list(axes.ravel())


def save(fig, name, out=DOCS):
    """Write ``fig`` to ``out/name`` (PNG) and return the file name for markdown."""
    out.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(out / name, dpi=110, bbox_inches="tight")  # keys placed beside the axes stay in
    plt.close(fig)
    return name


def machine():
    """CPU model, cores, OS and the versions of Python and the numerical stack."""
    import matplotlib as mpl
    import numba
    import numpy
    import scipy

    import geomint

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as info:
            cpu = next(line.split(":", 1)[1].strip() for line in info if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            cwd=Path(__file__).parent,
            check=False,
        ).stdout.strip()
    except OSError:
        commit = ""
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "os": platform.platform(),
        "load (1 min, at start)": f"{load:.2f}",
        "python": sys.version.split()[0],
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "matplotlib": mpl.__version__,
        "geomint": f"{geomint.__version__} ({commit})",
    }
