"""What identify and select share: the regressor options, reading the training logs, settings."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import typer

from neckid.cli._app import error_console

#: The regressor of identify when neither --lags nor --orders is given (MATLAB's [2 2 1]).
DEFAULT_ORDERS = "2,2,1"

LAGS_OPTION = typer.Option(
    None,
    "--lags",
    help="OUTPUT_LAGS/INPUT_LAGS in samples, each lag listed: 1-3/8-10 is y(t-1..t-3),"
    " u(t-8..t-10) (the paper's regressor); 3/1 is y(t-3) alone, not an order (see --orders).",
)
ORDERS_OPTION = typer.Option(
    None,
    "--orders",
    metavar="NA,NB,NK",
    help="MATLAB-style orders instead of --lags: NA output lags, NB input lags from delay NK,"
    " e.g. 2,2,1 is y(t-1), y(t-2), u(t-1), u(t-2) (the default when neither is given).",
)


def refuse_repeated_paths(paths: Sequence[Path], what: str = "log") -> None:
    """The same file given twice (by any spelling of its path) is refused, naming it."""
    seen: dict[Path, Path] = {}
    for path in paths:
        key = Path(path).resolve()
        if key in seen:
            raise ValueError(
                f"{path} is given twice (also as {seen[key]}): the same {what} would count twice;"
                " give each run once"
            )
        seen[key] = Path(path)


def _regressor(
    method: str, lags: str | None, orders: str | None, conditions: Sequence[str]
) -> tuple[Any, str]:
    """The regressor from --lags or --orders (one of them), and how it was chosen.

    Neither: ``--orders 2,2,1``, or the scheduled model's own first-order regressor.
    """
    from neckid.cli.workflow import lone_lag_note, parse_lags, parse_orders
    from neckid.regressors import Lags

    if lags is not None and orders is not None:
        raise ValueError(f"give the regressor once: --lags {lags} or --orders {orders}, not both")
    if lags is not None:
        parsed, chosen_by = parse_lags(lags), f"--lags {lags}"
        note = lone_lag_note(parsed)
        if note is not None:
            error_console.print(f"note: {note}", markup=False, highlight=False)
    elif orders is not None:
        parsed, chosen_by = parse_orders(orders), f"--orders {orders}"
    elif method.startswith("scheduled") and not conditions:
        return None, "the scheduled model's first-order default"
    else:
        parsed, chosen_by = parse_orders(DEFAULT_ORDERS), "the default --orders " + DEFAULT_ORDERS
    return Lags(parsed.outputs, parsed.inputs, conditions=conditions), chosen_by


def _regressor_text(model: Any) -> str:
    """The fitted model's regressor in the --lags syntax when it has one shape, else its repr."""
    from neckid.cli.workflow import format_lags

    resolved = getattr(model, "lags_", None)
    return format_lags(resolved) if resolved is not None else "-"


def _method_settings(method: str, items: Sequence[str]) -> dict[str, Any]:
    """``--set NAME=VALUE`` items as keyword arguments of the method's class (names checked)."""
    import json

    from neckid.registry import get_method

    own_option = {"random_state": "--seed", "lags": "--lags"}
    known = sorted(set(get_method(method).estimator_class()._parameter_constraints) - {"lags"})
    options: dict[str, Any] = {}
    for item in items:
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise ValueError(f"--set takes NAME=VALUE (e.g. lipschitz=local); got {item!r}")
        if name in own_option:
            raise ValueError(f"--set {name}: give it with {own_option[name]} instead")
        if name not in known:
            raise ValueError(
                f"--set {name}: method {method!r} has no setting {name!r}; its settings are"
                f" {', '.join(known)}"
            )
        try:
            options[name] = json.loads(text)
        except json.JSONDecodeError:
            options[name] = text
    return options
