"""The ``neckid`` command line: demo, identify, select, validate, simulate, compare, benchmark, info.

``app`` is the Typer application (the ``neckid`` script). The commands live in modules by what
they work on (:mod:`neckid.cli.models`, :mod:`neckid.cli.compare`, :mod:`neckid.cli.runs`,
:mod:`neckid.cli.logs`, :mod:`neckid.cli.select`, :mod:`neckid.cli.resid`); importing
them registers them on ``app``. Every command runs under one error policy
(:func:`neckid.cli._app.handled`).
"""

from neckid.cli import compare, design, export, frequency, logs, models, resid, runs, select
from neckid.cli._app import app

__all__ = [
    "app",
    "compare",
    "design",
    "export",
    "frequency",
    "logs",
    "models",
    "resid",
    "runs",
    "select",
]
