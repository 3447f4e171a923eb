r"""C export of the designed PI and fractional controllers (``neckid design ... --out c.json``).

A step is :meth:`neckid.design.controllers.DesignedController.control_law`'s: from the error
:math:`e = r - y` [deg], the operator's output :math:`v = C s + D e` and next state
:math:`A s + B e` (the Tustin integrator, the lab's Grünwald–Letnikov sum as its shift
register, or Oustaloup's cascade, as the controller file rebuilds them), the gains (fixed, or
interpolated in the measured inclination as ``numpy.interp``), the command
:math:`k_p e + k_f v`, its saturation with conditional integration, and a NaN measurement held
as the last command. The controller is read through its attributes (``kp``, ``kf``,
``operator``, ``command_limit``, ``schedule``), so this module does not import the design layer.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.export.c.literals import c_array, c_double
from neckid.export.c.program import CModel

__all__ = ["c_controller"]

_INTERP = r"""
static double NAME_interp(double x, const double *fp)
{
    int j = 0;
    if (x < NAME_table[0]) return fp[0];
    if (x >= NAME_table[NAME_N_TABLE - 1]) return fp[NAME_N_TABLE - 1];
    while (!(x < NAME_table[j + 1])) ++j;
    return (fp[j + 1] - fp[j]) / (NAME_table[j + 1] - NAME_table[j]) * (x - NAME_table[j]) + fp[j];
}
"""

_STEP = (
    "    double error, v, wanted, command, kp, kf, nxt[NAME_N_STATES];\n"
    "    int i, k, hold = 0;\n"
    "    if (isnan(measurement)) return s->command;\n"
    "    error = reference - measurement;\n"
    "    v = 0.0;\n"
    "    for (k = 0; k < NAME_N_STATES; ++k) v += NAME_c[k] * s->x[k];\n"
    "    v = v + NAME_d * error;\n"
    "    for (i = 0; i < NAME_N_STATES; ++i) {\n"
    "        double total = 0.0;\n"
    "        for (k = 0; k < NAME_N_STATES; ++k) total += NAME_a[i][k] * s->x[k];\n"
    "        nxt[i] = total + NAME_b[i] * error;\n"
    "    }\n"
    "@GAINS@"
    "    wanted = kp * error + kf * v;\n"
    "    command = wanted;\n"
    "@LIMIT@"
    "    if (!hold)\n"
    "        for (i = 0; i < NAME_N_STATES; ++i) s->x[i] = nxt[i];\n"
    "    s->command = command;\n"
    "    return command;\n"
)


def c_controller(controller: Any) -> CModel:
    """The C export of a :class:`~neckid.design.controllers.DesignedController`."""
    op = controller.operator
    n = int(op.n_states)
    constants = [
        f"#define NAME_N_STATES {max(n, 1)}",
        c_array("NAME_a", np.asarray(op.a, dtype=np.float64).reshape(n, n)),
        c_array("NAME_b", op.b),
        c_array("NAME_c", op.c),
        f"static const double NAME_d = {c_double(op.d)};",
    ]
    schedule = controller.schedule
    if schedule is None:
        gains = f"    kp = {c_double(controller.kp)};\n    kf = {c_double(controller.kf)};\n"
    else:
        constants += [
            f"#define NAME_N_TABLE {int(np.size(schedule.inclinations))}",
            c_array("NAME_table", schedule.inclinations),
            c_array("NAME_kp", schedule.kp),
            c_array("NAME_kf", schedule.kf),
            _INTERP,
        ]
        gains = (
            "    kp = NAME_interp(measurement, NAME_kp);\n"
            "    kf = NAME_interp(measurement, NAME_kf);\n"
        )
    limit = ""
    if controller.command_limit is not None:
        value = c_double(controller.command_limit)
        limit = (
            f"    if (fabs(wanted) > {value}) {{\n"
            f"        command = copysign({value}, wanted);\n"
            "        if (error * wanted > 0.0) hold = 1;  /* conditional integration */\n"
            "    }\n"
        )
    step = _STEP.replace("@GAINS@", gains).replace("@LIMIT@", limit)
    if n == 0:
        step = step.replace("nxt[NAME_N_STATES]", "nxt[1]")
    notes = [
        f"{controller.kind} controller: e = reference - inclination [deg], v = C s + D e,",
        "s <- A s + B e, command = kp e + kf v [rad/s]"
        + (
            f", saturated at +-{controller.command_limit!r} with conditional integration"
            if controller.command_limit is not None
            else ", no saturation"
        ),
        "gains: "
        + (
            "interpolated in the measured inclination (numpy.interp)"
            if schedule is not None
            else f"kp = {controller.kp!r}, kf = {controller.kf!r}"
        ),
        f"operator: {op.method}, order {float(op.order)!r}, {n} states, ts = {float(op.ts)!r} s",
        "A NaN measurement is a failed read: the last command is returned, nothing changes.",
    ]
    return CModel(
        title=f"Designed {controller.kind} controller (neckid DesignedController)",
        notes=notes,
        state=[
            (f"double x[{max(n, 1)}]", "the operator's state s"),
            ("double command", "the last command [rad/s]"),
        ],
        constants="\n".join(constants),
        reset="    memset(s, 0, sizeof *s);\n",
        step=step,
        n_inputs=2,
        n_outputs=1,
        reset_rows=0,
        ts=float(op.ts),
        controller=True,
    )
