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
    """The same run given twice is refused, naming both.

    By any spelling of its path (a symlink), as a hard link (the same device and inode) or as a
    copy (the same bytes: SHA-256): training logs among themselves, test logs against them.
    """
    seen: dict[Any, Path] = {}
    for path in paths:
        path = Path(path)
        key: Any = path.resolve()
        try:
            status = path.stat()
        except OSError:
            status = None  # a missing file: its reader says so
        if status is not None:
            key = (status.st_dev, status.st_ino)
        if key in seen:
            how = "also as" if seen[key].resolve() == path.resolve() else "a hard link to"
            raise ValueError(
                f"{path} is given twice ({how} {seen[key]}): the same {what} would count twice;"
                " give each run once"
            )
        seen[key] = path
    by_content: dict[tuple[int, str], Path] = {}
    for path in map(Path, paths):
        digest = _content_key(path)
        if digest is None:
            continue
        if digest in by_content:
            raise ValueError(
                f"{path} holds the same bytes as {by_content[digest]} (a copy of one run): the"
                f" same {what} would count twice; give each run once"
            )
        by_content[digest] = path


def _content_key(path: Path) -> tuple[int, str] | None:
    """A regular file's size and SHA-256 (None for a folder, a missing or unreadable file)."""
    import hashlib

    try:
        if not path.is_file():
            return None
        digest = hashlib.sha256()
        with path.open("rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                digest.update(block)
        return path.stat().st_size, digest.hexdigest()
    except OSError:
        return None


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

    resolved = model.fitted_lags()
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
