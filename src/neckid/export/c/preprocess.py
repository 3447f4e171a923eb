"""A model's preprocessing as C: ``NAME_preprocess(n, u, y)`` applies it to a whole log in place.

The steps the MATLAB script carries (:data:`neckid.export.matlab_preprocess.WRITTEN_STEPS`) are
the ones written here, with the same arithmetic as :mod:`neckid.data.preprocess`: ``relative``
(the channel minus its first sample) and ``offset`` (minus its mean over a rest window, times
``ts·k`` from the first sample, the window's ends taken ``1e-9·ts`` early). The mean is summed
from the first sample on, so it may differ from NumPy's pairwise sum in its last bit. Any other
step (a low-pass filter, a resampling) is refused by :func:`preprocess_body`, naming it, unless
the caller accepts an export without it (``export --force``), whose header then says so.
"""

from __future__ import annotations

from typing import Any

from neckid.data.preprocess import Relative, RemoveOffset
from neckid.export.c.literals import c_double
from neckid.export.matlab_preprocess import WRITTEN_STEPS, unwritten_steps

__all__ = ["preprocess_body", "preprocess_notes"]


def _steps(model: Any) -> tuple[Any, ...]:
    pipeline = getattr(model, "preprocessing_", None)
    return () if pipeline is None else tuple(pipeline.steps)


def _where(model: Any, channel: str) -> tuple[str, int, int]:
    """``("u" or "y", column, row length)`` of a channel."""
    inputs, outputs = list(model.input_names_), list(model.output_names_)
    if channel in inputs:
        return "u", inputs.index(channel), len(inputs)
    if channel in outputs:
        return "y", outputs.index(channel), len(outputs)
    raise ValueError(f"preprocessing step on {channel!r}: the model has no such channel")


def preprocess_notes(model: Any, without: bool) -> list[str]:
    """The header's lines on the preprocessing (what NAME_preprocess does, what it leaves out)."""
    steps = _steps(model)
    if not steps:
        return ["preprocessing: none (NAME_preprocess leaves the log as it is)"]
    missing = unwritten_steps(model)
    if missing and not without:
        raise ValueError(
            f"the model was identified on preprocessed logs, and its step(s) {'; '.join(missing)}"
            f" cannot be written as C (only {' and '.join(WRITTEN_STEPS)} can): export with"
            " --to json (the steps are listed there), or give --force to write the C code"
            " without them"
        )
    lines = [f"preprocessing (NAME_preprocess, in order): {'; '.join(s.describe() for s in steps)}"]
    if missing:
        lines.append(f"NOT APPLIED (not written as C): {'; '.join(missing)}; apply them first")
    return lines


def _relative(array: str, column: int, width: int) -> str:
    return (
        f"    if (n > 0) {{  /* relative: minus the first sample */\n"
        f"        double first = {array}[{column}];\n"
        f"        for (k = 0; k < n; ++k) {array}[k * {width} + {column}] -= first;\n"
        "    }\n"
    )


def _offset(array: str, column: int, width: int, start: float, stop: float) -> str:
    low = f"({c_double(start)} - 1e-9 * NAME_TS)"
    high = f"({c_double(stop)} - 1e-9 * NAME_TS)"
    return (
        "    {  /* offset: minus the mean over the rest window */\n"
        "        double sum = 0.0, mean;\n"
        "        size_t count = 0;\n"
        "        for (k = 0; k < n; ++k) {\n"
        "            double elapsed = NAME_TS * (double)k;\n"
        f"            if (elapsed >= {low} && elapsed < {high}) {{\n"
        f"                sum += {array}[k * {width} + {column}];\n"
        "                ++count;\n"
        "            }\n"
        "        }\n"
        "        if (count == 0) return -1;\n"
        "        mean = sum / (double)count;\n"
        f"        for (k = 0; k < n; ++k) {array}[k * {width} + {column}] -= mean;\n"
        "    }\n"
    )


def preprocess_body(model: Any) -> str:
    """The body of ``int NAME_preprocess(size_t n, double *u, double *y)``."""
    steps = [s for s in _steps(model) if s.kind in WRITTEN_STEPS]
    if not steps:
        return "    (void)n; (void)u; (void)y;\n    return 0;\n"
    body = ["    size_t k;\n", "    (void)u; (void)y;\n"]
    for step in steps:
        array, column, width = _where(model, step.channel)
        if array == "y":
            body.append("    if (y == NULL) return -1;\n")
        if isinstance(step, Relative):
            body.append(_relative(array, column, width))
        elif isinstance(step, RemoveOffset):
            body.append(_offset(array, column, width, step.start, step.stop))
    body.append("    return 0;\n")
    return "".join(body)
