"""The first-order regressor of the scheduled model: which input is the command, with what delay.

:class:`~neckid.models.scheduled.model.GainScheduledModel` is first order in one output (the
inclination) and one command: ``[i(t−1), u(t−d)]``. :func:`first_order_terms` reads the command
and the delay ``d`` from a resolved regressor; :func:`default_lags` is the regressor when none is
given. Their errors say what to write on the command line (``--lags 1/D``, ``--inputs``) and in
Python (``Lags.arx(1, 1, D)``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from neckid.data.iodata import IOData
from neckid.regressors import Lags, ResolvedLags

__all__ = ["LAGS_HELP", "default_lags", "first_order_terms"]

#: How to give the scheduled model its regressor, on the command line and in Python.
LAGS_HELP = (
    "on the command line --lags 1/D with one input in --inputs and one output in --outputs,"
    " in Python Lags.arx(1, 1, D), or Lags(outputs=[1], inputs={'<command>': [D]}) to pick the"
    " command among several inputs (D >= 1 is the input delay in samples, 1 in the seed paper)"
)


def first_order_terms(resolved: ResolvedLags) -> tuple[int, int]:
    """``(input channel, delay)`` of a first-order regressor ``[i(t−1), u_c(t−d)]``."""
    out_terms = resolved.lag[resolved.source == 0]
    in_terms = np.flatnonzero(resolved.source == 1)
    if (
        len(resolved.output_names) != 1
        or out_terms.tolist() != [1]
        or in_terms.size != 1
        or int(resolved.lag[in_terms[0]]) < 1
    ):
        raise ValueError(
            "GainScheduledModel is first order in one output and one command: give"
            f" {LAGS_HELP}; got {resolved.to_lags()!r} on inputs {list(resolved.input_names)}"
            f" and outputs {list(resolved.output_names)}"
        )
    return int(resolved.channel[in_terms[0]]), int(resolved.lag[in_terms[0]])


def default_lags(experiments: Sequence[IOData]) -> Lags:
    """The regressor when none is given: ``Lags.arx(1, 1, 1)`` on data with one input.

    Raises
    ------
    ValueError
        If the data have no input, or several (the message names them and how to choose).

    Examples
    --------
    >>> from neckid import IOData
    >>> default_lags([IOData(np.zeros(3), np.zeros(3), ts=0.02)])
    Lags(outputs=[1], inputs=[1])
    """
    names = list(experiments[0].input_names)
    if len(names) == 1:
        return Lags.arx(1, 1, 1)
    if not names:
        raise ValueError(
            "GainScheduledModel needs a command among the inputs and the data have none: name it"
            " with --inputs on the command line (the velocity command in the rate form, a motor"
            " position in the position form)"
        )
    raise ValueError(
        f"GainScheduledModel needs one command and the data have {len(names)} inputs {names}:"
        f" on the command line keep one with --inputs (e.g. --inputs {names[0]}) and give"
        f" --lags 1/D; in Python give lags=Lags(outputs=[1], inputs={{{names[0]!r}: [D]}})"
        " (D >= 1 is the input delay in samples, 1 in the seed paper)"
    )
