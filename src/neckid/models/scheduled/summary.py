"""What a fitted scheduled model is, in numbers and words: its lines, units, range and points.

:func:`describe_schedule` is what ``neckid info MODEL`` shows of a
:class:`~neckid.models.scheduled.model.GainScheduledModel` (and prints with ``--json``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

__all__ = ["describe_schedule", "gain_unit", "polynomial_text"]


def gain_unit(form: str, command_unit: str, output_unit: str = "deg") -> str:
    """Unit of ``N``: ``(deg/s)/(rad/s)`` in the rate form, ``deg/rad`` in the position form.

    An unknown command unit (older files) is written ``(command unit)``.

    Examples
    --------
    >>> gain_unit("rate", "rad/s"), gain_unit("position", "rad")
    ('(deg/s)/(rad/s)', 'deg/rad')
    """
    out = output_unit or "deg"
    command = command_unit or "(command unit)"
    if "/" in command and not command.startswith("("):
        command = f"({command})"
    return f"({out}/s)/{command}" if form == "rate" else f"{out}/{command}"


def polynomial_text(name: str, coefficients: Sequence[float], variable: str = "i") -> str:
    """``N(i) = -0.059 i + 1.857``: a polynomial (highest power first) written out.

    Examples
    --------
    >>> polynomial_text("N", [-0.059, 1.857])
    'N(i) = -0.059 i + 1.857'
    >>> polynomial_text("P", [0.001, 0.0, -0.5])
    'P(i) = 0.001 i^2 + 0 i - 0.5'
    """
    degree = len(coefficients) - 1
    terms = []
    for power, value in zip(range(degree, -1, -1), coefficients, strict=True):
        number = f"{abs(value):.4g}"
        sign = "-" if value < 0 else "+"
        body = number + ("" if power == 0 else f" {variable}" + (f"^{power}" if power > 1 else ""))
        terms.append((sign, body))
    first_sign, first = terms[0]
    text = ("-" if first_sign == "-" else "") + first
    for sign, body in terms[1:]:
        text += f" {sign} {body}"
    return f"{name}({variable}) = {text}"


def _number(value: Any) -> float | None:
    """A float for JSON, ``None`` for NaN or a missing value."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def describe_schedule(model: Any) -> dict[str, Any]:
    """The schedule of a fitted :class:`GainScheduledModel`, ready for JSON.

    Returns
    -------
    dict
        ``form``, ``equation`` (in words), ``command`` and ``command_unit``, ``delay``
        [samples], ``gain`` and ``pole`` (each ``{"text", "coefficients", "unit", "rmse"}``,
        coefficients highest power first, inclination in degrees), ``schedule_range_deg``
        (``[low, high]``, ``None`` for an unbounded end), ``pole_bound``, ``segmentation`` (the
        rule that found the points) and ``points`` (one dict per row of ``operating_points_``:
        ``inclination_deg``, ``gain``, ``pole``, ``converged`` (``None`` when unknown),
        ``used``, ``start_s``, ``stop_s``, ``n_samples``, ``experiment``, ``kind``).
    """
    form = str(model.form)
    output = model.output_names_[0]
    command = model.input_names_[int(model.lags_.channel[model.lags_.source == 1][0])]
    unit = gain_unit(form, model.command_unit_, model.output_units_[0])
    d = int(model.delay_)
    if form == "rate":
        equation = (
            f"r(t) = P(s) r(t-1) + N(s) {command}(t-{d}); {output}(t) = {output}(t-1)"
            f" + ts r(t), r the rate of {output} [{model.output_units_[0] or 'deg'}/s]"
        )
    else:
        equation = f"{output}(t) = P(s) {output}(t-1) + N(s) {command}(t-{d})"
    points = [
        {
            "inclination_deg": _number(row.inclination),
            "gain": _number(row.gain),
            "pole": _number(row.pole),
            "converged": None if _number(row.converged) is None else bool(row.converged),
            "used": bool(row.used),
            "start_s": _number(row.start_s),
            "stop_s": _number(row.stop_s),
            "n_samples": int(row.n_samples),
            "experiment": int(row.experiment),
            "kind": str(row.kind),
        }
        for row in model.operating_points_.itertuples(index=False)
    ]
    return {
        "form": form,
        "equation": equation + f", s = {output}(t-1) held in the schedule range",
        "command": command,
        "command_unit": model.command_unit_,
        "delay": d,
        "gain": {
            "text": polynomial_text("N", model.gain_coefficients_.tolist()),
            "coefficients": model.gain_coefficients_.tolist(),
            "unit": unit,
            "rmse": _number(model.gain_rmse_),
        },
        "pole": {
            "text": polynomial_text("P", model.pole_coefficients_.tolist()),
            "coefficients": model.pole_coefficients_.tolist(),
            "unit": "-",
            "rmse": _number(model.pole_rmse_),
        },
        "schedule_range_deg": [_number(v) for v in model.schedule_range_],
        "pole_bound": float(model.pole_bound),
        "segmentation": str(model.segmentation_),
        "points": points,
    }
