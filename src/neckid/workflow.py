"""The pieces the command line shares with scripts: read a log, parse a lag text, build an estimator."""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

from neckid.data import IOData
from neckid.regressors import Lags

__all__ = ["METHODS", "make_estimator", "parse_lags", "read_log"]

Method = Literal["sm", "sm-linear", "sm-parallel", "nn", "arx", "rls"]
METHODS: tuple[str, ...] = ("sm", "sm-linear", "sm-parallel", "nn", "arx", "rls")

_RANGE = re.compile(r"^\s*(\d+)\s*(?:-\s*(\d+))?\s*$")


def _parse_lag_list(text: str, argument: str) -> list[int]:
    lags: list[int] = []
    for part in text.split(","):
        if not part.strip():
            continue
        match = _RANGE.match(part)
        if match is None:
            raise ValueError(
                f"{argument}: cannot read {part.strip()!r}; write lags as 1-3 or 1,2,3 or 8-10"
            )
        lo = int(match.group(1))
        hi = int(match.group(2)) if match.group(2) is not None else lo
        if hi < lo:
            raise ValueError(f"{argument}: range {part.strip()!r} goes backwards")
        lags.extend(range(lo, hi + 1))
    return lags


def parse_lags(text: str) -> Lags:
    """Read a regressor from text: ``"OUTPUT_LAGS/INPUT_LAGS"``, each a list of lags or ranges.

    The same lags apply to every output and every input. ``"1-3/8-10"`` is the seed paper's
    regressor ``[y(t-1..t-3), u(t-8..t-10)]``; ``"1,2/0-2"`` uses ``y(t-1), y(t-2), u(t), u(t-1), u(t-2)``.

    Examples
    --------
    >>> parse_lags("1-3/8-10")
    Lags(outputs=[1, 2, 3], inputs=[8, 9, 10])
    """
    if text.count("/") != 1:
        raise ValueError(
            f"--lags must look like OUTPUT_LAGS/INPUT_LAGS, e.g. 1-3/8-10; got {text!r}"
        )
    out_text, in_text = text.split("/")
    return Lags(
        outputs=_parse_lag_list(out_text, "--lags (outputs)"),
        inputs=_parse_lag_list(in_text, "--lags (inputs)"),
    )


def read_log(
    path: str | Path,
    inputs: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
    *,
    time: str | None = "time",
    ts: float | None = None,
    layout: Literal["csv", "softneck"] = "csv",
) -> IOData:
    """Read a log for identification.

    Parameters
    ----------
    path : path
        A CSV with a header row (``layout="csv"``), a Parquet or ``.mat`` file (by extension), or
        one of the lab's headerless soft-neck logs (``layout="softneck"``, see
        :func:`neckid.datasets.load_softneck_log`).
    inputs, outputs : sequence of str
        Channel names. Required for CSV/Parquet/MAT; for soft-neck logs they select among the
        loader's named channels (default: all of them).
    time, ts : see :meth:`IOData.from_csv`.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"log file {str(path)!r} does not exist")
    if layout == "softneck":
        from neckid.datasets import load_softneck_log

        data = load_softneck_log(path)
        if inputs or outputs:
            data = data.select(
                inputs=list(inputs) if inputs else None, outputs=list(outputs) if outputs else None
            )
        return data
    if layout != "csv":
        raise ValueError(f"layout must be 'csv' or 'softneck'; got {layout!r}")
    if not inputs:
        raise ValueError("--inputs is required for a CSV log: name the input column(s)")
    suffix = path.suffix.lower()
    if ts is not None:
        time = None
    if suffix == ".parquet":
        return IOData.from_parquet(path, list(inputs), list(outputs or ()), time=time, ts=ts)
    if suffix == ".mat":
        return IOData.from_mat(path, list(inputs), list(outputs or ()), time=time, ts=ts)
    return IOData.from_csv(path, list(inputs), list(outputs or ()), time=time, ts=ts)


def make_estimator(method: str, lags: Lags, *, random_state: int | None = 0, **options: Any) -> Any:
    """Build an unfitted estimator by method name.

    ``"sm"``: :class:`~neckid.SetMembership`; ``"sm-linear"``: the same with a linear part;
    ``"sm-parallel"``: :class:`~neckid.ParallelSetMembership` (``lags`` are its linear ARX's);
    ``"nn"``: :class:`~neckid.NeuralNARX` (2 × 25); ``"arx"``: :class:`~neckid.LinearARX`;
    ``"rls"``: :class:`~neckid.RecursiveARX` (λ = 0.98) with ``na``/``nb``/``delay`` taken from
    contiguous ``lags``.
    """
    if method == "sm" or method == "sm-linear":
        from neckid.models.set_membership import SetMembership

        return SetMembership(lags, linear_part=method == "sm-linear", **options)
    if method == "sm-parallel":
        from neckid.models.sm_parallel import ParallelSetMembership

        return ParallelSetMembership(lags, **options)
    if method == "nn":
        from neckid.models.neural import NeuralNARX

        return NeuralNARX(lags, random_state=random_state, **options)
    if method == "arx":
        from neckid.models.arx import LinearARX

        return LinearARX(lags, **options)
    if method == "rls":
        from neckid.models.rls import RecursiveARX

        na, nb, delay = _contiguous_orders(lags)
        return RecursiveARX(na=na, nb=nb, delay=delay, **options)
    raise ValueError(f"method must be one of {list(METHODS)}; got {method!r}")


def _contiguous_orders(lags: Lags) -> tuple[int, int, int]:
    if isinstance(lags.outputs, dict) or isinstance(lags.inputs, dict):
        raise ValueError(
            "the rls method needs the same lags for every channel, e.g. --lags 1-2/1-2"
        )
    outs, ins = list(lags.outputs), list(lags.inputs)
    if outs != list(range(1, len(outs) + 1)):
        raise ValueError(f"the rls method needs output lags 1..na; got {outs}")
    if ins and ins != list(range(ins[0], ins[0] + len(ins))):
        raise ValueError(f"the rls method needs contiguous input lags d..d+nb-1; got {ins}")
    return len(outs), len(ins), (ins[0] if ins else 1)
