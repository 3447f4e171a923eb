"""The ``neckid`` command line."""

from __future__ import annotations

import logging

import typer
from rich.console import Console

from neckid._version import __version__

app = typer.Typer(
    name="neckid",
    help="Identify dynamic models of a tendon-driven soft robotic neck from input/output logs.",
    no_args_is_help=True,
    add_completion=False,
)
console = Console()


def _version_callback(value: bool) -> None:
    if value:
        console.print(f"neckid {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: bool = typer.Option(
        False,
        "--version",
        callback=_version_callback,
        is_eager=True,
        help="Print the version and exit.",
    ),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Log progress messages."),
) -> None:
    """Identify dynamic models of a tendon-driven soft robotic neck from input/output logs."""
    logging.basicConfig(
        level=logging.INFO if verbose else logging.WARNING, format="%(name)s: %(message)s"
    )


@app.command()
def info() -> None:
    """Print the versions of neckid and of the libraries it uses."""
    import numpy
    import scipy
    import sklearn

    console.print(
        f"neckid {__version__}, numpy {numpy.__version__}, scipy {scipy.__version__},"
        f" scikit-learn {sklearn.__version__}"
    )
