"""C export of the multi-step Set Membership model (``sm-multistep``): chained direct predictors.

Each direct predictor of horizon ``k`` (an SM map, :func:`~neckid.export.c.set_membership.
sm_map_parts`) is written under its own prefix ``NAME_p<k>_``. A step is
:class:`~neckid.models.set_membership.multistep.MultiStepSimulator`'s: the ``k``-th step after
the anchor applies predictor ``k`` to the anchored outputs and the inputs since, its band widened
by the model's ``epsilon[k - 1]``; after ``horizon`` steps the last outputs are the new anchor.
"""

from __future__ import annotations

from typing import Any

from neckid.export.c.literals import c_array
from neckid.export.c.program import CModel
from neckid.export.c.set_membership import sm_map_parts

__all__ = ["c_multistep"]


def _predictor(sub: Any, k: int, history: int) -> tuple[str, str]:
    """The constants and map function of predictor ``k``, and its call in the step."""
    constants, map_code, _ = sm_map_parts(sub)
    tag = f"NAME_p{k}_"
    lags = sub.lags_
    terms = []
    for j, (source, channel, lag) in enumerate(
        zip(lags.source.tolist(), lags.channel.tolist(), lags.lag.tolist(), strict=True)
    ):
        buffer = "y" if source == 0 else "u"
        terms.append(f"    w[{j}] = s->{buffer}[{history + k - 1 - lag}][{channel}];\n")
    function = (
        f"static void NAME_map(const double *w, double *out, double *lower, double *upper)\n{{\n"
        f"{map_code}}}"
    )
    text = (constants + "\n" + function).replace("NAME_", tag)
    call = (
        f"    case {k}: {{\n"
        f"        double w[{max(int(lags.n_terms), 1)}];\n"
        + "".join("    " + line for line in terms)
        + f"        {tag}map(w, out, lower, upper);\n"
        "        break;\n"
        "    }\n"
    )
    return text, call


def c_multistep(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.MultiStepSetMembership`."""
    horizon = int(model.horizon)
    history = max(int(model.max_lag_), 1)
    n_in, n_out = len(model.input_names_), len(model.output_names_)
    parts = [
        _predictor(sub, k, history) for k, sub in enumerate(model.estimators_[:horizon], start=1)
    ]
    constants = "\n".join(
        [
            f"#define NAME_H {history}",
            f"#define NAME_HORIZON {horizon}",
            c_array("NAME_epsilon", model.epsilon_),
            *(text for text, _ in parts),
        ]
    )
    reset = (
        "    if (y0 != NULL) memcpy(s->y, y0, sizeof s->y[0] * NAME_H);\n"
        "    else memset(s->y, 0, sizeof s->y);\n"
        "    if (u0 != NULL) memcpy(s->u, u0, sizeof s->u[0] * NAME_H);\n"
        "    else memset(s->u, 0, sizeof s->u);\n"
        "    s->steps = 0;\n"
    )
    step = (
        "    double out[NAME_N_OUTPUTS];\n"
        "    int k = s->steps + 1, t = NAME_H + s->steps, o;\n"
        "    memcpy(s->u[t], u, sizeof s->u[t]);\n"
        "    switch (k) {\n"
        + "".join(call for _, call in parts[:-1])
        + "    default:  /* k == NAME_HORIZON */\n"
        + parts[-1][1]
        + "    }\n"
        "    for (o = 0; o < NAME_N_OUTPUTS; ++o) {\n"
        "        lower[o] = lower[o] - NAME_epsilon[k - 1][o];\n"
        "        upper[o] = upper[o] + NAME_epsilon[k - 1][o];\n"
        "        s->y[t][o] = out[o];\n"
        "        y[o] = out[o];\n"
        "    }\n"
        "    if (k == NAME_HORIZON) {  /* the last outputs anchor the next block */\n"
        "        memmove(s->y[0], s->y[t + 1 - NAME_H], sizeof s->y[0] * NAME_H);\n"
        "        memmove(s->u[0], s->u[t + 1 - NAME_H], sizeof s->u[0] * NAME_H);\n"
        "        s->steps = 0;\n"
        "    } else {\n"
        "        s->steps = k;\n"
        "    }\n"
    )
    notes = [
        f"Multi-step Set Membership: {horizon} direct predictors chained in blocks of {horizon};",
        "the k-th step after the anchor applies predictor k (an SM map on the anchored outputs",
        "and the inputs since), its band [f_l - epsilon_k, f_u + epsilon_k] (guaranteed in the",
        "first block only); y the central estimate.",
        f"State: the anchor's M = {history} rows of outputs and inputs and the block's rows",
        f"since, the steps since the anchor; NAME_reset takes M = {history} rows.",
    ]
    return CModel(
        title="Multi-step Set Membership (neckid MultiStepSetMembership)",
        notes=notes,
        state=[
            (f"double y[{history + horizon}][{n_out}]", "anchored outputs, then the block's"),
            (f"double u[{history + horizon}][{n_in}]", "anchored inputs, then the block's"),
            ("int steps", "steps since the anchor"),
        ],
        constants=constants,
        reset=reset,
        step=step,
        n_inputs=n_in,
        n_outputs=n_out,
        reset_rows=history,
        ts=float(model.ts_),
        bounded=True,
        initial_rows=int(model.max_lag_),
    )
