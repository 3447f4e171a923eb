"""The select command: choose the regressor on the user's own logs, by the safe rule."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.markup import escape

from neckid.cli._app import (
    FORCE_OPTION,
    LOG_HELP,
    _method_name,
    app,
    console,
    error_console,
    handled,
)
from neckid.cli._training import _method_settings
from neckid.cli.options import LogSpec, attach_log_options, log_options, read_training_logs
from neckid.registry import methods

#: The candidate grid of select when neither --orders nor --lags is given: MATLAB's
#: ``struc(1:3, 1:3, 0:3)``, 36 candidates.
DEFAULT_GRID = "1-3,1-3,0-3"


def _candidates(orders: str | None, lags: list[str] | None) -> list[Any]:
    """The candidates: the --orders grid and every --lags; the default grid when neither."""
    from neckid.cli.workflow import lone_lag_note, parse_lags, parse_order_grid

    grid = parse_order_grid(orders) if orders is not None else []
    for text in lags or []:
        parsed = parse_lags(text)
        note = lone_lag_note(parsed)  # as identify says it: 3/1 is y(t-3) alone, not na = 3
        if note is not None:
            error_console.print(f"note: {note}", markup=False, highlight=False)
        if parsed not in grid:
            grid.append(parsed)
    return grid or parse_order_grid(DEFAULT_GRID)


def _with_conditions(candidates: list[Any], conditions: list[str] | tuple[str, ...]) -> list[Any]:
    """Every candidate with ``conditions`` as constant inputs (``--use-conditions``)."""
    from neckid.regressors import Lags

    if not conditions:
        return candidates
    return [Lags(c.outputs, c.inputs, conditions=conditions) for c in candidates]


def _listed(text: str | None) -> list[str]:
    """``a,b`` as ``["a", "b"]``; none for None."""
    return [p.strip() for p in (text or "").split(",") if p.strip()]


def _ranking_rows(selection: Any, data: Any, limit: int) -> list[dict[str, Any]]:
    """One printed row per candidate (best mean fold fit first), at most ``limit``."""
    from neckid.cli.workflow import format_lags

    column = selection.column
    rows = []
    for _, row in selection.table.head(limit).iterrows():
        lags = selection.candidates[int(row["candidate"])]
        try:
            text = format_lags(lags.resolve(data))
        except (KeyError, ValueError):
            text = repr(lags)
        rows.append(
            {
                "lags": text,
                "terms": row["n_terms"],
                "mean fit [%]": row[column],
                "± se [points]": row[f"{column}_se"],
                "to best [points]": row[f"{column}_diff"],
                "± paired se": row[f"{column}_diff_se"],
                "worst fold [%]": row[f"{column}_worst"],
                "status": row["status"],
                "reason": str(row["reason"])[:60],
            }
        )
    return rows


def _print_ranking(selection: Any, data: Any, limit: int) -> None:
    from rich.table import Table

    kind = "free run" if selection.criterion == "simulation" else "one step ahead"
    table = Table(
        title=f"{selection.scheme}, {selection.table['n_folds'].iloc[0]} folds: fit ({kind})"
    )
    rows = _ranking_rows(selection, data, limit)
    for name in rows[0]:
        table.add_column(
            name,
            justify="left" if name in ("lags", "status", "reason") else "right",
            overflow="fold",  # a narrow console wraps a candidate's lags, never cuts them
        )
    for row in rows:
        cells = []
        for value in row.values():
            if isinstance(value, float):
                cells.append("-" if value != value else f"{value:.2f}")  # NaN: no spread
            else:
                cells.append(str(value))
        table.add_row(*cells, style="bold" if row["status"] == "chosen" else None)
    console.print(table)
    if len(selection.table) > limit:
        console.print(f"({len(selection.table) - limit} more candidates; --json has every one)")


def _document(selection: Any, data: Any, method: str, chosen: str | None) -> dict[str, Any]:
    """What ``--json`` writes: the rule, the folds, every candidate's mean and fold fits."""
    column = selection.column
    folds = selection.folds
    candidates = []
    for row, (_, full) in zip(
        _ranking_rows(selection, data, len(selection.table)),
        selection.table.iterrows(),
        strict=True,
    ):
        candidates.append(
            {
                "lags": row["lags"],
                "n_terms": row["terms"],
                "mean_fit_percent": row["mean fit [%]"],
                "se_points": row["± se [points]"],
                "difference_to_best_points": row["to best [points]"],
                "difference_se_points": row["± paired se"],
                "worst_fold_percent": row["worst fold [%]"],
                "status": row["status"],
                "reason": str(full["reason"]),
                "fold_fits_percent": list(full[f"{column}_folds"]),
            }
        )
    return {
        "method": method,
        "fit": "free run" if column == "fit_simulation" else "one step ahead",
        "rule": selection.rule,
        "scheme": selection.scheme,
        "folds": folds,
        "chosen": chosen,
        **_choice(selection, data),
        "baselines": dict(selection.baselines),
        "warnings": list(selection.warnings),
        "candidates": candidates,
    }


def _choice(selection: Any, data: Any) -> dict[str, Any]:
    """The best candidate by mean fold fit, the bar, and each fold's gap of the chosen one."""
    ranking = selection.ranking
    if ranking is None:
        return {}
    names = _names(selection, data)
    return {
        "best": names[ranking.best],
        "best_fit_mean_percent": float(ranking.means[ranking.best]),
        "bar_percent": ranking.bar,
        "fold_differences_to_best_points": [float(d) for d in ranking.differences[ranking.chosen]],
        "explanation": selection.explain(names),
    }


def _names(selection: Any, data: Any) -> list[str]:
    """Every candidate as --lags writes it (its repr when it cannot be resolved)."""
    from neckid.cli.workflow import format_lags

    names = []
    for lags in selection.candidates:
        try:
            names.append(format_lags(lags.resolve(data)))
        except (KeyError, ValueError):
            names.append(repr(lags))
    return names


@app.command()
@handled
@log_options(training=True)
def select(
    logs: list[Path] = typer.Argument(
        ...,
        metavar="LOG...",
        help=LOG_HELP + " Several logs: each is held out once; one log: 3 time blocks.",
        exists=True,
    ),
    method: str = typer.Option("arx", "--method", help=" | ".join(methods()) + "."),
    orders: str = typer.Option(
        None,
        "--orders",
        metavar="NA,NB,NK",
        help="The candidate grid, MATLAB's struc(na, nb, nk): each a number or a range, e.g."
        f" 1-3,1-3,0-3 (the default when no --lags is given: {DEFAULT_GRID}, 36 candidates).",
    ),
    lags: list[str] = typer.Option(
        None,
        "--lags",
        help="A candidate in the identify syntax, OUTPUT_LAGS/INPUT_LAGS (1-3/8-10); repeat the"
        " option, and combine it with --orders.",
    ),
    criterion: str = typer.Option(
        "simulation", "--criterion", help="simulation (free-run fit) or prediction (one step)."
    ),
    rule: str = typer.Option(
        "safe",
        "--rule",
        help="safe: out if it fails or diverges in a fold, then the fewest terms within one"
        " standard error of the best mean fold fit; best: the best mean fold fit.",
    ),
    top: int = typer.Option(15, "--top", min=1, help="Candidates to print (best first)."),
    save: Path = typer.Option(
        None, "--save", help="Fit the chosen regressor on all the logs and save the model (.npz)."
    ),
    json_out: Path = typer.Option(
        None, "--json", help="Write every candidate's fold fits and the choice as JSON."
    ),
    jobs: int = typer.Option(1, "--jobs", help="Parallel fits (-1: every core)."),
    settings: list[str] = typer.Option(
        None, "--set", metavar="NAME=VALUE", help="A setting of the method, as in identify."
    ),
    use_conditions: str = typer.Option(
        None,
        "--use-conditions",
        help="Comma-separated conditions every candidate takes as constant inputs (e.g."
        " payload), as in identify; each log must have them.",
    ),
    force: bool = FORCE_OPTION,
    *,
    spec: LogSpec,
) -> None:
    """Choose the regressor on your logs: every candidate is fitted with logs held out.

    Example: neckid select run1.csv run2.csv --inputs velocity_command --outputs inclination --orders 1-3,1-3,0-3 --save model.npz

    Scores are free-run fits of the held-out logs (or time blocks of one log). A candidate that
    fails or diverges in a fold is out; the fewest terms whose per-fold difference to the best
    is within one standard error of that difference is chosen; a choice below the training mean
    or 0 % is said in one warning line. The test logs you keep for the end are not given here.
    """
    from neckid.cli.workflow import format_lags, make_estimator
    from neckid.selection.lags import select_lags
    from neckid.utils.files import check_output_file, output_name, write_json

    if criterion not in ("simulation", "prediction"):
        raise ValueError(f"--criterion must be simulation or prediction; got {criterion!r}")
    if save is not None:
        save = output_name(save, ".npz", option="--save")
        check_output_file(save, force=force, inputs=list(logs), option="--save")
    if json_out is not None:
        check_output_file(json_out, force=force, inputs=list(logs), option="--json")
    method = _method_name(method)
    if methods()[method].lag_free:  # every candidate would be the same model
        raise ValueError(
            f"--method {method}: select chooses among lag sets, and {method} reads no lags (its"
            " order or structure comes from the data), so every candidate would be the same model:"
            f" fit it with neckid identify --method {method}, or compare it with other methods in"
            " neckid compare"
        )
    experiments, pipeline = read_training_logs(logs, spec)
    options = _method_settings(method, settings or ())
    estimator = make_estimator(method, None, **options)  # type: ignore[arg-type]
    selection = select_lags(
        experiments if len(experiments) > 1 else experiments[0],
        None,
        _with_conditions(_candidates(orders, lags), _listed(use_conditions)),
        estimator,
        criterion=criterion,  # type: ignore[arg-type]
        rule=rule,  # type: ignore[arg-type]
        n_jobs=jobs,
        progress=True,  # the command's reporter: a bar in a terminal, a line every 10 s otherwise
    )
    _print_ranking(selection, experiments[0], top)
    chosen = None if selection.chosen is None else selection.best_lags
    text = (
        None if chosen is None else format_lags(chosen.resolve(chosen.conditioned(experiments[0])))
    )
    if json_out is not None:
        write_json(json_out, _document(selection, experiments[0], method, text))
        console.print(f"ranking written to {json_out}")
    if chosen is None:
        raise ValueError("every candidate failed or diverged in a fold; see the reason column")
    console.print(f"chosen: --lags {text} ({selection.rule} rule)", markup=False)
    console.print(f"  {selection.explain(_names(selection, experiments[0]))}", markup=False)
    shown = ", ".join(f"{k} {v:.1f} %" for k, v in selection.baselines.items()) or "none applies"
    console.print(f"  baselines on the same folds: {shown}", markup=False)
    for line in selection.warnings:  # a result, not an error: the exit status stays 0
        console.print(f"[yellow]warning:[/yellow] {escape(line)}", highlight=False, soft_wrap=True)
    if save is not None:
        model = make_estimator(method, chosen, **options)
        model.fit(experiments if len(experiments) > 1 else experiments[0])
        attach_log_options(model, spec, pipeline)
        console.print(f"model fitted on all {len(experiments)} log(s), saved to {model.save(save)}")
