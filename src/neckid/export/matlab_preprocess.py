"""A model's preprocessing written into its MATLAB script (``export --to tf``), or refused.

A model identified on preprocessed logs (``identify --relative motor_position --offset
inclination:0:2``) takes the preprocessed channels: a MATLAB user who feeds the log's absolute
motor positions to the exported transfer function gets another model's answer. The steps that
are one line of MATLAB are written into the script as code, applied to ``U`` and ``Y`` when
they are in the workspace: ``relative`` (the channel minus its first sample) and ``offset``
(minus its mean over a rest window, times counted ``Ts`` per sample from the first, as neckid
counts them). The others (a low-pass filter started at rest, a resampling, new time stamps, the
tilt vector) are refused: :func:`preprocessing_lines` raises, naming the step, unless the
caller accepts a script without them (``export --force``), which then says so in its header.
"""

from __future__ import annotations

from typing import Any

from neckid.data.preprocess import Relative, RemoveOffset, Step

__all__ = ["WRITTEN_STEPS", "preprocessing_lines", "unwritten_steps"]

#: The preprocessing steps the script carries as code.
WRITTEN_STEPS = (Relative.kind, RemoveOffset.kind)


def _steps(model: Any) -> tuple[Step, ...]:
    pipeline = getattr(model, "preprocessing_", None)
    return () if pipeline is None else tuple(pipeline.steps)


def unwritten_steps(model: Any) -> list[str]:
    """The model's preprocessing steps a MATLAB script cannot carry, described."""
    return [step.describe() for step in _steps(model) if step.kind not in WRITTEN_STEPS]


def _number(value: float) -> str:
    return repr(float(value))


def _where(model: Any, channel: str) -> tuple[str, int]:
    """``("U", column)`` or ``("Y", column)`` of a channel, 1-based as MATLAB counts."""
    inputs, outputs = list(model.input_names_), list(model.output_names_)
    if channel in inputs:
        return "U", inputs.index(channel) + 1
    if channel in outputs:
        return "Y", outputs.index(channel) + 1
    raise ValueError(f"preprocessing step on {channel!r}: the model has no such channel")


def preprocessing_lines(model: Any, *, without: bool = False) -> list[str]:
    """The script's lines that apply the model's preprocessing to ``U`` and ``Y``.

    Parameters
    ----------
    model : fitted estimator
        Its ``preprocessing_`` (``None``: nothing to write).
    without : bool, default False
        Accept steps the script cannot carry: they are listed in a comment instead.

    Raises
    ------
    ValueError
        If a step cannot be written as MATLAB code and ``without`` is False (the message names
        the step and what to do).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> from neckid.data.preprocess import Pipeline, Relative
    >>> data = IOData(np.arange(20.0), np.arange(20.0) ** 0.5, ts=0.1, input_names=["m"])
    >>> model = LinearARX(Lags.arx(1, 1)).fit(data)
    >>> model.preprocessing_ = Pipeline([Relative("m")])
    >>> print(preprocessing_lines(model)[-2])
      U(:, 1) = U(:, 1) - U(1, 1);  % relative m
    """
    steps = _steps(model)
    if not steps:
        return []
    missing = unwritten_steps(model)
    if missing and not without:
        raise ValueError(
            f"the model was identified on preprocessed logs, and its step(s) {'; '.join(missing)}"
            f" cannot be written into a MATLAB script (only {' and '.join(WRITTEN_STEPS)} can):"
            " a MATLAB user would feed it the raw log; export with --to json or --to mat (the"
            " steps are listed there), or give --force to write the script without them"
        )
    lines = [
        "% Preprocessing: the model was identified on logs preprocessed by these steps, in order;",
        "% they are applied to U (one column per input_names) and Y (one per output_names) when",
        "% both are in the workspace: load a log into U and Y, then run this script.",
    ]
    if missing:
        lines.append(
            f"% NOT APPLIED (not writable as MATLAB code): {'; '.join(missing)}. Apply them to"
            " the log yourself first."
        )
    lines.append("if exist('U', 'var') && exist('Y', 'var')")
    for step in steps:
        if isinstance(step, Relative):
            name, j = _where(model, step.channel)
            lines.append(
                f"  {name}(:, {j}) = {name}(:, {j}) - {name}(1, {j});  % {step.describe()}"
            )
        elif isinstance(step, RemoveOffset):
            name, j = _where(model, step.channel)
            since = f"(0:size({name}, 1) - 1)' * Ts"
            low, high = (f"{_number(s)} - 1e-9 * Ts" for s in (step.start, step.stop))
            rest = f"{since} >= {low} & {since} < {high}"
            lines.append(
                f"  {name}(:, {j}) = {name}(:, {j}) - mean({name}({rest}, {j}));"
                f"  % {step.describe()}"
            )
    lines.append("end")
    return lines
