r"""C export of the predictive controller (``neckid design ... --mpc``): its data and OSQP's own code.

The controller's step is :class:`~neckid.design.mpc.controller.MPCController`'s: the measurement
enters the history and moves the disturbance estimate, the QP's linear term and bounds are
computed from the prediction matrices (written out exactly), the solver is warm-started from the
previous plan shifted by one step, and the first move is clipped to the rate and command
limits; a failed solve holds the previous command. The QP is solved by the code OSQP generates
for it (``osqp.OSQP.codegen``, embedded mode 1: only the vectors change), written beside the
controller in ``NAME_osqp/`` with every symbol prefixed ``NAME_``: the same solver, on the same
matrices with the same settings, as the Python controller. It has no time limit (the embedded
code has no clock): a real-time loop bounds the iterations (``max_iter``) instead.

The controller is read through its public attributes (``problem``, ``kind``) and the settings
its own module publishes (``SOLVER_SETTINGS``), so this module imports no design code.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

from neckid.export.c.literals import c_array, c_double
from neckid.export.c.program import CModel

__all__ = ["c_mpc", "qp_matrices"]


def qp_matrices(problem: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(hessian, constraints)`` of the controller's QP: ``2 H`` and the rows of ``l <= A x <= u``.

    The variables are the ``N_u`` moves (and, with output limits, one slack per horizon step);
    the rows the commands, their moves, and the output limits with their slacks.
    """
    d, nu = int(problem.delay), int(problem.control_horizon)
    phi = problem.forced[d:]
    moves = np.eye(nu) - np.eye(nu, k=-1)
    hessian = problem.tracking_weight * phi.T @ phi + problem.move_weight * moves.T @ moves
    blocks = [np.eye(nu), moves]
    if problem.constrained:
        n = int(problem.horizon)
        hessian = np.block(
            [[hessian, np.zeros((nu, n))], [np.zeros((n, nu)), problem.slack_weight * np.eye(n)]]
        )
        blocks = [
            np.column_stack([np.eye(nu), np.zeros((nu, n))]),
            np.column_stack([moves, np.zeros((nu, n))]),
            np.column_stack([phi, -np.eye(n)]),
            np.column_stack([phi, np.eye(n)]),
            np.column_stack([np.zeros((n, nu)), np.eye(n)]),
        ]
    return 2.0 * hessian, np.vstack(blocks)


def _solver_settings(controller: Any) -> dict[str, Any]:
    module = sys.modules.get(type(controller).__module__)
    settings = getattr(module, "SOLVER_SETTINGS", None)
    if not isinstance(settings, dict):
        raise TypeError(f"{type(controller).__name__} publishes no SOLVER_SETTINGS: no C export")
    return dict(settings)


def _bounds_at_rest(problem: Any) -> tuple[np.ndarray, np.ndarray]:
    """The QP's bounds at rest: which rows are two-sided, one-sided or free.

    OSQP chooses each row's step size ``rho`` by that kind at setup; the embedded code keeps
    them (it never refactors), so the setup must see the kinds the steps' bounds will have.
    """
    nu, n = int(problem.control_horizon), int(problem.horizon)
    step = float(problem.rate_limit) * float(problem.ts)
    limit = float(problem.command_limit)
    lower = [np.full(nu, -limit), np.full(nu, -step)]
    upper = [np.full(nu, limit), np.full(nu, step)]
    if problem.constrained:
        tightening = np.asarray(problem.tightening, dtype=np.float64).reshape(-1)
        lower += [np.full(n, -np.inf), problem.output_min + tightening, np.zeros(n)]
        upper += [problem.output_max - tightening, np.full(n, np.inf), np.full(n, np.inf)]
    return np.concatenate(lower), np.concatenate(upper)


def _generate(controller: Any, name: str, folder: Path) -> list[Path]:
    """OSQP's generated code for the controller's QP, in ``folder / f"{name}_osqp"``."""
    import osqp
    import scipy.sparse as sp

    problem = controller.problem
    hessian, constraints = qp_matrices(problem)
    lower, upper = _bounds_at_rest(problem)
    solver = osqp.OSQP()
    solver.setup(
        sp.csc_matrix(np.triu(hessian)),
        np.zeros(hessian.shape[0]),
        sp.csc_matrix(constraints),
        lower,
        upper,
        verbose=False,
        warm_starting=True,
        polishing=False,
        **_solver_settings(controller),
    )
    target = folder / f"{name}_osqp"
    solver.codegen(str(target), parameters="vectors", force_rewrite=True, prefix=f"{name}_")
    return sorted(p for p in target.rglob("*") if p.is_file())


def _constants(problem: Any) -> str:
    d, n, nu = int(problem.delay), int(problem.horizon), int(problem.control_horizon)
    constrained = bool(problem.constrained)
    lines = [
        f"#define NAME_NA {int(problem.a.size)}",
        f"#define NAME_NP {int(problem.n_past_commands)}",
        f"#define NAME_NH {int(problem.n_history)}",
        f"#define NAME_N {n}",
        f"#define NAME_NU {nu}",
        f"#define NAME_NV {nu + (n if constrained else 0)}",
        f"#define NAME_NC {2 * nu + (3 * n if constrained else 0)}",
        f"#define NAME_PREVIEW {int(bool(problem.preview))}",
        f"#define NAME_CONSTRAINED {int(constrained)}",
        c_array("NAME_free", problem.free[d:]),
        c_array("NAME_free0", problem.free[0]),
        c_array("NAME_forced", problem.forced[d:]),
        c_array("NAME_forced0", problem.forced[0]),
        c_array("NAME_dist", problem.disturbance[d:]),
        f"static const double NAME_dist0 = {c_double(problem.disturbance[0])};",
        c_array("NAME_tightening", np.asarray(problem.tightening).reshape(-1)),
    ]
    for key in (
        "tracking_weight",
        "move_weight",
        "command_limit",
        "rate_limit",
        "slack_linear_weight",
        "disturbance_gain",
        "output_min",
        "output_max",
        "ts",
    ):
        lines.append(f"static const double NAME_{key} = {c_double(getattr(problem, key))};")
    return "\n".join(lines)


_STEP = r"""    double y = measurement, r = reference, history[NAME_NH], base[NAME_N], refs[NAME_N];
    double q[NAME_NV], l[NAME_NC], u[NAME_NC], shifted[NAME_NV], step, command, predicted;
    int i, j, status;
    if (isnan(y)) {
        s->k += 1;
        return s->last;
    }
    /* the measurement: the history, the disturbance estimate */
    if (!s->started) {
        for (i = 0; i < NAME_NA; ++i) s->y[i] = y;
        s->started = 1;
    } else {
        for (i = NAME_NA - 1; i > 0; --i) s->y[i] = s->y[i - 1];
        s->y[0] = y;
    }
    if (s->has_prediction) s->delta += NAME_disturbance_gain * (y - s->predicted);
    /* the references over the horizon */
    for (j = 0; j < NAME_N; ++j) {
        if (NAME_PREVIEW && s->future != NULL) {
            size_t index = (size_t)s->k + (size_t)j + 1;
            refs[j] = s->future[index < s->n_future ? index : s->n_future - 1];
        } else {
            refs[j] = r;
        }
    }
    for (i = 0; i < NAME_NA; ++i) history[i] = s->y[i];
    for (i = 0; i < NAME_NP; ++i) history[NAME_NA + i] = s->u[i];
    for (j = 0; j < NAME_N; ++j) {
        double total = 0.0;
        for (i = 0; i < NAME_NH; ++i) total += NAME_free[j][i] * history[i];
        base[j] = total + NAME_dist[j] * s->delta;
    }
    for (i = 0; i < NAME_NU; ++i) {
        double total = 0.0;
        for (j = 0; j < NAME_N; ++j) total += NAME_forced[j][i] * (base[j] - refs[j]);
        q[i] = 2.0 * NAME_tracking_weight * total;
    }
    q[0] -= 2.0 * NAME_move_weight * s->last;
    step = NAME_rate_limit * NAME_ts;
    for (i = 0; i < NAME_NU; ++i) {
        l[i] = -NAME_command_limit;
        u[i] = NAME_command_limit;
        l[NAME_NU + i] = -step + (i == 0 ? s->last : 0.0);
        u[NAME_NU + i] = step + (i == 0 ? s->last : 0.0);
    }
    if (NAME_CONSTRAINED) {
        for (j = 0; j < NAME_NV - NAME_NU; ++j) {
            int row = 2 * NAME_NU;
            q[NAME_NU + j] = NAME_slack_linear_weight;
            l[row + j] = -OSQP_INFTY;
            u[row + j] = NAME_output_max - NAME_tightening[j] - base[j];
            l[row + NAME_N + j] = NAME_output_min + NAME_tightening[j] - base[j];
            u[row + NAME_N + j] = OSQP_INFTY;
            l[row + 2 * NAME_N + j] = 0.0;
            u[row + 2 * NAME_N + j] = OSQP_INFTY;
        }
    }
    for (i = 0; i < NAME_NC; ++i) {  /* OSQP's infinity for the limits a double calls inf */
        if (l[i] < -OSQP_INFTY) l[i] = -OSQP_INFTY;
        if (u[i] > OSQP_INFTY) u[i] = OSQP_INFTY;
    }
    osqp_update_data_vec(&NAME_solver, q, l, u);
    for (i = 0; i + 1 < NAME_NU; ++i) shifted[i] = s->plan[i + 1];
    shifted[NAME_NU - 1] = s->plan[NAME_NU - 1];
    for (i = NAME_NU; i + 1 < NAME_NV; ++i) shifted[i] = s->plan[i + 1];
    if (NAME_NV > NAME_NU) shifted[NAME_NV - 1] = s->plan[NAME_NV - 1];
    osqp_warm_start(&NAME_solver, shifted, NULL);
    osqp_solve(&NAME_solver);
    status = (int)NAME_solver.info->status_val;
    command = s->last;
    if (status == OSQP_SOLVED || status == OSQP_SOLVED_INACCURATE) {
        for (i = 0; i < NAME_NV; ++i) s->plan[i] = NAME_solver.solution->x[i];
        command = s->plan[0];
        if (command < s->last - step) command = s->last - step;
        if (command > s->last + step) command = s->last + step;
        if (command < -NAME_command_limit) command = -NAME_command_limit;
        if (command > NAME_command_limit) command = NAME_command_limit;
    } else {
        s->failed += 1;
    }
    /* the next prediction of this measurement's successor, then the command into the history */
    predicted = 0.0;
    for (i = 0; i < NAME_NH; ++i) predicted += NAME_free0[i] * history[i];
    {
        double forced = 0.0;
        for (i = 0; i < NAME_NU; ++i) forced += NAME_forced0[i] * command;
        predicted = predicted + forced + NAME_dist0 * s->delta;
    }
    s->predicted = predicted;
    s->has_prediction = 1;
    for (i = NAME_NP - 1; i > 0; --i) s->u[i] = s->u[i - 1];
    s->u[0] = command;
    s->last = command;
    s->k += 1;
    return command;
"""


def c_mpc(controller: Any) -> CModel:
    """The C export of an :class:`~neckid.design.mpc.MPCController`."""
    problem = controller.problem
    _solver_settings(controller)  # refused here, before any file, when it has none
    n_v = int(problem.control_horizon) + (int(problem.horizon) if problem.constrained else 0)
    notes = [
        "Linear MPC: the first move of the QP of the module neckid.design.mpc.problem, solved by",
        "OSQP's generated code (NAME_osqp/, symbols prefixed NAME_), warm-started from the",
        "previous plan shifted by one step; clipped to the rate and command limits; a failed",
        "solve holds the previous command (counted in s->failed); no time limit.",
        f"horizon N = {int(problem.horizon)}, control horizon {int(problem.control_horizon)},"
        f" delay {int(problem.delay)}, command limit {float(problem.command_limit)!r} rad/s,"
        f" rate limit {float(problem.rate_limit)!r} rad/s^2,",
        f"output limits [{float(problem.output_min)!r}, {float(problem.output_max)!r}] deg,"
        f" preview {bool(problem.preview)} (NAME_set_reference gives the run's reference)",
        "Compile with the files of NAME_osqp/src, -I NAME_osqp/inc/public -I NAME_osqp/inc/private",
        "-I NAME_osqp, and NAME_osqp/NAME_workspace.c.",
    ]
    return CModel(
        title="Model predictive controller (neckid MPCController)",
        notes=notes,
        state=[
            (f"double y[{int(problem.a.size)}]", "past inclinations, newest first [deg]"),
            (f"double u[{int(problem.n_past_commands)}]", "past commands, newest first [rad/s]"),
            ("double delta", "the output disturbance estimate [deg]"),
            ("double predicted", "the prediction of the next measurement [deg]"),
            ("int has_prediction", "whether predicted holds one"),
            ("int started", "whether a measurement came"),
            ("long k", "steps since reset"),
            ("double last", "the last command [rad/s]"),
            (f"double plan[{n_v}]", "the last solution (the warm start)"),
            ("const double *future", "the run's reference for the preview (NULL: none)"),
            ("size_t n_future", "its length"),
            ("long failed", "solves that failed (the command held)"),
        ],
        constants=_constants(problem),
        reset="    memset(s, 0, sizeof *s);\n    s->future = NULL;\n",
        step=_STEP,
        n_inputs=2,
        n_outputs=1,
        reset_rows=0,
        ts=float(problem.ts),
        controller=True,
        includes=['"osqp.h"', '"NAME_workspace.h"'],
        extra_api=[
            "/* The run's reference [deg] for the preview: step k reads reference[k + 1 .. k + N]",
            "   (the last value held); NULL: hold the current one. Kept by pointer. */",
            "void NAME_set_reference(NAME_state *s, const double *reference, size_t n);",
        ],
        extra_source=(
            "void NAME_set_reference(NAME_state *s, const double *reference, size_t n)\n{\n"
            "    s->future = n > 0 ? reference : NULL;\n    s->n_future = n;\n}"
        ),
        companion=lambda folder, name: _generate(controller, name, folder),
        companion_folder="NAME_osqp",
    )
