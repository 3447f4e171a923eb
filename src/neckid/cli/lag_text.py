"""Regressors as text: the ``--lags`` and ``--orders`` syntax of the command line.

``--lags OUTPUT_LAGS/INPUT_LAGS`` lists every lag (``1-3/8-10`` is ``y(t-1..t-3), u(t-8..t-10)``);
``--orders NA,NB,NK`` gives MATLAB's orders (``arx(data, [na nb nk])``); ``neckid select`` takes
ranges of orders (``struc(1:3, 1:3, 0:3)``).
"""

from __future__ import annotations

import re

from neckid.regressors import Lags, ResolvedLags

__all__ = [
    "format_lags",
    "lone_lag_note",
    "parse_lags",
    "parse_order_grid",
    "parse_orders",
]

_RANGE = re.compile(r"^\s*(\d+)\s*(?:-\s*(\d+))?\s*$")

#: The longest lag (and the most lags) a regressor text may give, in samples: what a model file
#: may claim (:mod:`neckid.models.io`). Checked before the list of lags is built.
MAX_LAG = 100_000

#: The most candidates ``--orders`` ranges may give ``select``: checked before they are built.
MAX_CANDIDATES = 10_000


def _parse_lag_list(text: str, argument: str) -> list[int]:
    spans: list[tuple[int, int]] = []
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
        if hi > MAX_LAG:
            raise ValueError(
                f"{argument}: lag {hi} in {part.strip()!r} is beyond {MAX_LAG} samples, more than"
                " a model can remember: give shorter lags (e.g. 1-10), or resample the log"
                " (--resample) so that the same time spans fewer samples"
            )
        spans.append((lo, hi))
    if sum(hi - lo + 1 for lo, hi in spans) > MAX_LAG:
        raise ValueError(f"{argument}: {text.strip()!r} lists more than {MAX_LAG} lags; give fewer")
    return [lag for lo, hi in spans for lag in range(lo, hi + 1)]


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


def parse_orders(text: str) -> Lags:
    """Read MATLAB-style orders ``"NA,NB,NK"`` as the regressor ``Lags.arx(NA, NB, NK)``.

    ``NA`` output lags ``1..NA``, ``NB`` input lags from the delay ``NK`` on (``NK..NK+NB-1``),
    as MATLAB's ``arx(data, [na nb nk])`` and ``idpoly``: ``"2,2,1"`` is ``y(t-1), y(t-2),
    u(t-1), u(t-2)``.

    Examples
    --------
    >>> parse_orders("2,2,1")
    Lags(outputs=[1, 2], inputs=[1, 2])
    >>> parse_orders("3,1,8")
    Lags(outputs=[1, 2, 3], inputs=[8])
    """
    na, nb, nk = _order_ranges(text, "--orders")
    if len(na) != 1 or len(nb) != 1 or len(nk) != 1:
        raise ValueError(
            f"--orders takes one NA,NB,NK (e.g. 2,2,1); got ranges in {text!r}: ranges are for"
            " neckid select"
        )
    if na[0] == 0 and nb[0] == 0:
        raise ValueError(f"--orders {text}: NA and NB are both 0, so the model has no term")
    return Lags.arx(na[0], nb[0], nk[0])


def parse_order_grid(text: str) -> list[Lags]:
    """Read ``"NA,NB,NK"`` where each is a number or a range ``lo-hi``: every combination.

    MATLAB's ``struc(1:3, 1:3, 0:2)``: ``"1-3,1-3,0-2"`` is 27 candidates
    (:func:`~neckid.selection.lags.lag_grid`).

    Examples
    --------
    >>> len(parse_order_grid("1-3,1-3,0-2")), parse_order_grid("2,2,1-2")[1]
    (27, Lags(outputs=[1, 2], inputs=[2, 3]))
    """
    from neckid.selection.lags import lag_grid

    na, nb, nk = _order_ranges(text, "--orders")
    count = len(na) * len(nb) * len(nk)
    if count > MAX_CANDIDATES:
        raise ValueError(
            f"--orders {text}: {count} candidates ({len(na)} x {len(nb)} x {len(nk)}), more than"
            f" {MAX_CANDIDATES} a selection fits in reasonable time: narrow the ranges"
        )
    return lag_grid(na, nb, nk)


def _order_ranges(text: str, argument: str) -> tuple[list[int], list[int], list[int]]:
    parts = [part.strip() for part in str(text).split(",")]
    if len(parts) != 3 or not all(parts):
        raise ValueError(
            f"{argument} must be NA,NB,NK (output order, input order, input delay in samples),"
            f" e.g. 2,2,1 or ranges 1-3,1-3,0-2; got {text!r}"
        )
    names = ("NA", "NB", "NK")
    ranges = [
        _parse_lag_list(part, f"{argument} ({name})")
        for part, name in zip(parts, names, strict=True)
    ]
    return ranges[0], ranges[1], ranges[2]


def format_lags(resolved: ResolvedLags) -> str:
    """A resolved regressor in the ``--lags`` syntax, or its ``Lags`` repr.

    The ``--lags`` text when all outputs share their lags and all inputs theirs (no conditions).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> data = IOData(np.zeros((5, 2)), np.zeros(5), ts=0.1)
    >>> format_lags(Lags.arx(2, 2, 1).resolve(data))
    '1-2/1-2'
    >>> format_lags(Lags(outputs=[1, 3], inputs=[0]).resolve(data))
    '1,3/0'
    """

    def text(lags: list[int]) -> str:
        if not lags:
            return ""
        if lags == list(range(lags[0], lags[-1] + 1)) and len(lags) > 1:
            return f"{lags[0]}-{lags[-1]}"
        return ",".join(str(lag) for lag in lags)

    groups = []
    for source, count in ((0, len(resolved.output_names)), (1, len(resolved.input_names))):
        per_channel = {
            tuple(
                int(lag)
                for lag in resolved.lag[(resolved.source == source) & (resolved.channel == c)]
            )
            for c in range(count)
        }
        if len(per_channel) > 1:
            return repr(resolved.to_lags())
        groups.append(text(list(next(iter(per_channel)))) if per_channel else "")
    if resolved.conditions:
        return repr(resolved.to_lags())
    return "/".join(groups)


def lone_lag_note(lags: Lags) -> str | None:
    """A note when ``--lags`` gives one output lag above 1: likely meant as an order.

    ``--lags 3/1-3`` is ``y(t-3)`` alone, where a MATLAB user means ``na = 3``; the note says
    how to write either.

    Examples
    --------
    >>> print(lone_lag_note(parse_lags("3/1-3")))
    --lags 3/...: the output lag 3 alone, y(t-3); for the lags 1 to 3 write --lags 1-3/... or --orders 3,NB,NK
    >>> lone_lag_note(parse_lags("1-3/8-10")) is None
    True
    """
    outputs = lags.outputs
    if isinstance(outputs, list | tuple) and len(outputs) == 1 and isinstance(outputs[0], int):
        lag = outputs[0]
        if lag > 1:
            return (
                f"--lags {lag}/...: the output lag {lag} alone, y(t-{lag}); for the lags 1 to"
                f" {lag} write --lags 1-{lag}/... or --orders {lag},NB,NK"
            )
    return None
