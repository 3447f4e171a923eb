"""The residual tests from the command line: ``neckid resid`` and ``validate --resid``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.markup import escape

from neckid.cli._app import FORCE_OPTION, LOG_HELP, app, console, handled
from neckid.cli.options import LogSpec, log_options, read_for_model

__all__ = ["RESID_HELP", "resid", "resid_record"]

#: The help of ``validate --resid``.
RESID_HELP = (
    "Also run the residual tests on each log (as `neckid resid`: whiteness of the one-step"
    " residuals and their independence of the inputs, 99 % confidence, 25 lags)."
)


def _tests(model: Any, data: Any, max_lag: int) -> Any:
    """The tests, a too large ``--lags`` named as the option."""
    from neckid.selection.residuals import residual_tests

    try:
        return residual_tests(model, data, max_lag=max_lag, confidence=0.99)
    except ValueError as exc:
        if str(exc).startswith(f"max_lag={max_lag} is too large"):
            raise ValueError(
                "--lags " + str(exc).removeprefix("max_lag=").replace("max_lag", "--lags")
            ) from None
        raise


def _print_tests(tests: Any, title: str) -> None:
    """The tests in words: which residual, one line per test, the verdict."""
    console.print(
        f"{escape(title)}: residual tests on the {tests.residual} residual,"
        f" {tests.residuals.shape[0]} samples after the model's {tests.n_initial} initial"
        f" one(s), lags up to {tests.max_lag} samples"
        f" ({tests.max_lag * tests.ts:.4g} s)",
        highlight=False,
        soft_wrap=True,
    )
    for line in tests.lines():
        style = "red" if "FAILED" in line or line.startswith("verdict: failed") else None
        console.print(f"  {line}", style=style, markup=False, highlight=False, soft_wrap=True)


def resid_record(model: Any, data: Any, log: Path, max_lag: int = 25) -> dict[str, Any]:
    """Run and print the residual tests of ``model`` on one log; their JSON record (validate)."""
    tests = _tests(model, data, max_lag)
    _print_tests(tests, log.name)
    return tests.to_dict()


@app.command()
@handled
@log_options(training=False)
def resid(
    model_path: Path = typer.Argument(
        ..., metavar="MODEL", help="A model file written by identify.", exists=True
    ),
    log: Path = typer.Argument(..., metavar="LOG", help=LOG_HELP, exists=True, dir_okay=False),
    lags: int = typer.Option(
        25,
        "--lags",
        min=1,
        max=100_000,
        metavar="M",
        help="The largest lag of the tests [samples] (MATLAB resid's 25): the autocorrelation"
        " at 1..M, the cross-correlations at -M..M.",
    ),
    plot: Path = typer.Option(
        None,
        "--plot",
        help="Write a PNG of the autocorrelations and cross-correlations with their 99 % band.",
    ),
    json_out: Path = typer.Option(
        None,
        "--json",
        help="Write the tests as JSON: per output and input-output pair, the correlations, the"
        " band, the chi-square statistic, its threshold and the verdict.",
    ),
    force: bool = FORCE_OPTION,
    *,
    spec: LogSpec,
) -> None:
    """Ljung's residual tests of a saved model on one log (MATLAB's resid), at 99 % confidence.

    Whiteness: the one-step residuals' autocorrelation at lags 1..M and N sum r^2, chi-square
    with M degrees of freedom. Independence: the residual-input cross-correlation at -M..M and
    its chi-square statistic, per input-output pair. A model whose predict is its free run
    (an output-error model: sm-parallel, pnlss, grey-box ODE) is tested on its free-run error,
    and the output says so.
    """
    from neckid.models.io import load_model
    from neckid.utils.files import check_output_file, write_json

    for path, option in ((plot, "--plot"), (json_out, "--json")):
        if path is not None:
            check_output_file(path, force=force, inputs=[log, model_path], option=option)
    model = load_model(model_path)
    data = read_for_model(model, log, spec)
    tests = _tests(model, data, lags)
    _print_tests(tests, f"{model_path.name} on {log.name}")
    if json_out is not None:
        document = {"model": model_path.name, "log": log.name, **tests.to_dict()}
        write_json(json_out, document)
        console.print(f"results written to {json_out}")
    if plot is not None:
        from neckid.cli.explain import _save_figure
        from neckid.report.residual_plots import plot_residual_tests

        _save_figure(plot_residual_tests(tests), plot)
        console.print(f"figure written to {plot}")
