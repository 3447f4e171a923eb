"""C export of the gain-scheduled first-order model (``scheduled``, ``scheduled-position``).

A step is :class:`~neckid.models.scheduled.simulator.GainScheduledSimulator`'s: the gain and the
pole at the last inclination clipped to the schedule's range (Horner's rule, as
``numpy.polyval``), the pole held in ``±pole_bound``, then the rate form ``r = P r + N u(t-d)``,
``i = i + ts r`` or the position form ``i = P i + N u(t-d)``, ``r = (i - i_prev) / ts``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.export.c.literals import c_array, c_double
from neckid.export.c.program import CModel

__all__ = ["c_scheduled"]

_HORNER = r"""
static double NAME_polyval(const double *coefficients, int size, double inclination)
{
    double s = inclination, value = 0.0;
    int k;
    if (s < NAME_range[0]) s = NAME_range[0];
    if (s > NAME_range[1]) s = NAME_range[1];
    for (k = 0; k < size; ++k) value = value * s + coefficients[k];
    return value;
}
"""


def c_scheduled(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.GainScheduledModel`."""
    delay = int(model.delay_)
    lags = model.lags_
    channel = int(lags.channel[lags.source == 1][0])
    size = int(np.size(model.gain_coefficients_))
    bound = c_double(float(model.pole_bound))
    constants = "\n".join(
        [
            f"#define NAME_DELAY {delay}",
            f"#define NAME_SIZE {size}",
            f"#define NAME_COMMAND {channel}",
            c_array("NAME_gain", model.gain_coefficients_),
            c_array("NAME_pole", model.pole_coefficients_),
            c_array("NAME_range", model.schedule_range_),
            _HORNER,
        ]
    )
    reset = (
        "    int k;\n"
        "    double command = u0 != NULL ? u0[NAME_COMMAND] : 0.0;\n"
        "    s->inclination = y0 != NULL ? y0[0] : 0.0;\n"
        "    s->rate = 0.0;\n"
        "    for (k = 0; k < NAME_DELAY; ++k) s->past_u[k] = command;\n"
    )
    if model.form == "position":
        law = (
            "    previous = s->inclination;\n"
            "    s->inclination = pole * previous + gain * s->past_u[0];\n"
            "    s->rate = (s->inclination - previous) / NAME_TS;\n"
        )
        equation = "i(t) = P(s) i(t-1) + N(s) u(t-d), r(t) = (i(t) - i(t-1)) / ts"
    else:
        law = (
            "    (void)previous;\n"
            "    s->rate = pole * s->rate + gain * s->past_u[0];\n"
            "    s->inclination = s->inclination + NAME_TS * s->rate;\n"
        )
        equation = "r(t) = P(s) r(t-1) + N(s) u(t-d), i(t) = i(t-1) + ts r(t)"
    step = (
        "    double gain = NAME_polyval(NAME_gain, NAME_SIZE, s->inclination);\n"
        "    double pole = NAME_polyval(NAME_pole, NAME_SIZE, s->inclination);\n"
        "    double previous;\n"
        "    int k;\n"
        f"    if (pole < -{bound}) pole = -{bound};\n"
        f"    if (pole > {bound}) pole = {bound};\n"
        + law
        + "    for (k = 0; k + 1 < NAME_DELAY; ++k) s->past_u[k] = s->past_u[k + 1];\n"
        "    s->past_u[NAME_DELAY - 1] = u[NAME_COMMAND];\n"
        "    y[0] = s->inclination;\n"
    )
    command = list(model.input_names_)[channel]
    notes = [
        f"{equation}; u = {command}, i the inclination [deg], s = i(t-1) clipped to the",
        "schedule's range; N(s), P(s) polynomials (highest power first), P held in",
        f"[-pole_bound, pole_bound], pole_bound = {float(model.pole_bound)!r}",
        f"State: inclination i(t-1) [deg], rate r(t-1) [deg/s], the last d = {delay} commands.",
        "NAME_reset takes 1 row: y0[0] the inclination, u0 the inputs (the command repeated",
        "d times), the rate 0; simulate's first sample is that row.",
    ]
    return CModel(
        title=f"Gain-scheduled first-order model, {model.form} form (neckid GainScheduledModel)",
        notes=notes,
        state=[
            ("double inclination", "i(t-1) [deg]"),
            ("double rate", "r(t-1) [deg/s]"),
            (f"double past_u[{delay}]", "u(t-d) ... u(t-1), the command, oldest first"),
        ],
        constants=constants,
        reset=reset,
        step=step,
        n_inputs=len(model.input_names_),
        n_outputs=1,
        reset_rows=1,
        ts=float(model.ts_),
        initial_rows=1,
    )
