"""C export of a Set Membership NARX model: its data set as constant arrays, the exact bounds.

The model's kd-tree (:class:`~neckid.models.set_membership._kernels.tree.SMTree`) is written out
as it is: the scaled training regressors and their targets in tree order, each node's range of
points, children, bounding box and target range. The generated ``NAME_query`` is the same branch
and bound as the compiled one (the pruning test never skips a point that would change a bound,
so the bounds are those of a scan over every point, bit for bit), and a step is the compiled
free run's: the linear part summed from the intercept term by term,

``f_u = min_k (y_k + gamma ||ws - W_k||) + eps``, ``f_l = max_k (y_k - gamma ||ws - W_k||) - eps``,

``ws = w .* weights``, the outputs ``linear + [f_l, f_u]`` and the central estimate ``linear +
(f_l + f_u) / 2`` fed back (Milanese & Novara, Automatica 2004). With local Lipschitz
constants (``lipschitz="local"``) point ``k`` bounds with ``max(gamma(w), gamma_k)``,
``gamma(w)`` the largest ``gamma_k`` within the ``K``-th smallest distance from ``w``, found by
a scan over the data set (the same squared distances as the Python kernel's kd-tree walk).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.export.c.literals import c_array, c_int_array
from neckid.export.c.narx import narx_model
from neckid.export.c.program import CModel

__all__ = ["c_set_membership", "sm_map_parts"]

_QUERY = r"""
static double NAME_box_distance(const double *ws, long node)
{
    double acc = 0.0;
    int k;
    for (k = 0; k < NAME_N_TERMS; ++k) {
        double v = ws[k];
        if (v < NAME_lo[node][k]) {
            double diff = NAME_lo[node][k] - v;
            acc += diff * diff;
        } else if (v > NAME_hi[node][k]) {
            double diff = v - NAME_hi[node][k];
            acc += diff * diff;
        }
    }
    return sqrt(acc);
}

/* max_k (y_k - gamma d_k) into *lower, min_k (y_k + gamma d_k) into *upper (no epsilon). */
static void NAME_query(const double *ws, int c, double gamma, double *lower, double *upper)
{
    long node_stack[NAME_STACK_DEPTH];
    double dist_stack[NAME_STACK_DEPTH];
    double best_upper = HUGE_VAL, best_lower = -HUGE_VAL;
    int top = 1;
    node_stack[0] = 0;
    dist_stack[0] = NAME_box_distance(ws, 0);
    while (top > 0) {
        long node, child;
        double reach;
        top -= 1;
        node = node_stack[top];
        reach = gamma * dist_stack[top];
        if (NAME_ymin[node][c] + reach >= best_upper && NAME_ymax[node][c] - reach <= best_lower)
            continue;
        child = NAME_left[node];
        if (child < 0) {
            long p;
            for (p = NAME_start[node]; p < NAME_end[node]; ++p) {
                double acc = 0.0, gd, v;
                int k;
                for (k = 0; k < NAME_N_TERMS; ++k) {
                    double diff = ws[k] - NAME_points[p][k];
                    acc += diff * diff;
                }
#if NAME_LOCAL
                {  /* the point's own constant where it is larger: max(gamma, gamma_k) */
                    double own = NAME_point_gamma[p][c];
                    gd = (own > gamma ? own : gamma) * sqrt(acc);
                }
#else
                gd = gamma * sqrt(acc);
#endif
                v = NAME_targets[p][c];
                if (v + gd < best_upper) best_upper = v + gd;
                if (v - gd > best_lower) best_lower = v - gd;
            }
        } else {  /* the nearer child is explored first */
            long other = NAME_right[node];
            double d_left = NAME_box_distance(ws, child);
            double d_right = NAME_box_distance(ws, other);
            if (d_left <= d_right) {
                node_stack[top] = other; dist_stack[top] = d_right;
                node_stack[top + 1] = child; dist_stack[top + 1] = d_left;
            } else {
                node_stack[top] = child; dist_stack[top] = d_left;
                node_stack[top + 1] = other; dist_stack[top + 1] = d_right;
            }
            top += 2;
        }
    }
    *lower = best_lower;
    *upper = best_upper;
}
"""

_NEIGHBOURS = r"""
/* gamma(w) per output: the largest constant of the training points within the K-th smallest
   squared distance (ties included), as the local prior's kernel finds it. */
static void NAME_neighbour_gamma(const double *ws, double *out)
{
    double near[NAME_K];
    long p;
    int k, c, slot;
    for (k = 0; k < NAME_K; ++k) near[k] = HUGE_VAL;
    for (p = 0; p < NAME_N_POINTS; ++p) {
        double acc = 0.0;
        for (k = 0; k < NAME_N_TERMS; ++k) {
            double diff = ws[k] - NAME_points[p][k];
            acc += diff * diff;
        }
        if (acc < near[NAME_K - 1]) {
            slot = NAME_K - 1;
            while (slot > 0 && near[slot - 1] > acc) {
                near[slot] = near[slot - 1];
                slot -= 1;
            }
            near[slot] = acc;
        }
    }
    if (!(near[NAME_K - 1] < HUGE_VAL)) {
        for (c = 0; c < NAME_N_MAP_OUTPUTS; ++c) out[c] = HUGE_VAL;
        return;
    }
    for (c = 0; c < NAME_N_MAP_OUTPUTS; ++c) out[c] = 0.0;
    for (p = 0; p < NAME_N_POINTS; ++p) {
        double acc = 0.0;
        for (k = 0; k < NAME_N_TERMS; ++k) {
            double diff = ws[k] - NAME_points[p][k];
            acc += diff * diff;
        }
        if (acc <= near[NAME_K - 1])
            for (c = 0; c < NAME_N_MAP_OUTPUTS; ++c)
                if (NAME_point_gamma[p][c] > out[c]) out[c] = NAME_point_gamma[p][c];
    }
}
"""

_LOCAL_MAP = (
    "    {\n"
    "        double ws[NAME_N_TERMS], near_gamma[NAME_N_MAP_OUTPUTS];\n"
    "        int k, c;\n"
    "        for (k = 0; k < NAME_N_TERMS; ++k) ws[k] = w[k] * NAME_weights[k];\n"
    "        NAME_neighbour_gamma(ws, near_gamma);\n"
    "        for (c = 0; c < NAME_N_MAP_OUTPUTS; ++c) {\n"
    "            double linear = NAME_intercept[c], low, high, f_lower, f_upper;\n"
    "            double g = near_gamma[c];\n"
    "            for (k = 0; k < NAME_N_TERMS; ++k) linear += w[k] * NAME_coef[k][c];\n"
    "            NAME_query(ws, c, g, &low, &high);\n"
    "            if (low - high > 2.0 * NAME_epsilon[c] && NAME_gamma[c] > g) {\n"
    "                g = NAME_gamma[c];  /* crossed by rounding only: the global constant */\n"
    "                NAME_query(ws, c, g, &low, &high);\n"
    "            }\n"
    "            f_lower = low - NAME_epsilon[c];\n"
    "            f_upper = high + NAME_epsilon[c];\n"
    "            lower[c] = linear + f_lower;\n"
    "            upper[c] = linear + f_upper;\n"
    "            out[c] = linear + 0.5 * (f_lower + f_upper);\n"
    "        }\n"
    "    }\n"
)

_MAP = (
    "    {\n"
    "        double ws[NAME_N_TERMS];\n"
    "        int k, c;\n"
    "        for (k = 0; k < NAME_N_TERMS; ++k) ws[k] = w[k] * NAME_weights[k];\n"
    "        for (c = 0; c < NAME_N_MAP_OUTPUTS; ++c) {\n"
    "            double linear = NAME_intercept[c], low, high, f_lower, f_upper;\n"
    "            for (k = 0; k < NAME_N_TERMS; ++k) linear += w[k] * NAME_coef[k][c];\n"
    "            NAME_query(ws, c, NAME_gamma[c], &low, &high);\n"
    "            f_lower = low - NAME_epsilon[c];\n"
    "            f_upper = high + NAME_epsilon[c];\n"
    "            lower[c] = linear + f_lower;\n"
    "            upper[c] = linear + f_upper;\n"
    "            out[c] = linear + 0.5 * (f_lower + f_upper);\n"
    "        }\n"
    "    }\n"
)


def sm_map_parts(model: Any) -> tuple[str, str, list[str]]:
    """``(constants, map code, notes)`` of a fitted SetMembership's map from ``w[]`` to the band.

    The map code reads ``w[]`` and writes ``out[]``, ``lower[]`` and ``upper[]``; a model that
    steps several maps (the multi-step predictors) embeds each under its own prefix.

    """
    core = model.core_
    local = core.point_gamma is not None
    points, targets, start, end, left, right, lo, hi, ymin, ymax = core.tree.kernel_arrays()
    n_terms = int(points.shape[1])
    constants = "\n".join(
        [
            f"#define NAME_N_TERMS {n_terms}",
            f"#define NAME_N_MAP_OUTPUTS {int(targets.shape[1])}",
            f"#define NAME_N_POINTS {int(points.shape[0])}",
            f"#define NAME_N_NODES {int(start.shape[0])}",
            "#define NAME_STACK_DEPTH 128",
            f"#define NAME_LOCAL {int(local)}",
            f"#define NAME_K {max(min(int(core.local_neighbours), int(points.shape[0])), 1)}",
            c_array("NAME_weights", core.weights),
            c_array("NAME_coef", np.asarray(core.coef).reshape(n_terms, -1)),
            c_array("NAME_intercept", core.intercept),
            c_array("NAME_epsilon", core.epsilon),
            c_array("NAME_gamma", core.gamma),
            "/* the data set: scaled regressors W_k (w .* weights) and targets y_k, tree order */",
            c_array("NAME_points", points),
            c_array("NAME_targets", targets),
            "/* the kd-tree: node n holds points start[n] .. end[n] - 1; left < 0 for a leaf */",
            c_int_array("NAME_start", start),
            c_int_array("NAME_end", end),
            c_int_array("NAME_left", left),
            c_int_array("NAME_right", right),
            c_array("NAME_lo", lo),
            c_array("NAME_hi", hi),
            c_array("NAME_ymin", ymin),
            c_array("NAME_ymax", ymax),
            "/* each training point's own Lipschitz constant (local prior), tree order */"
            if local
            else "",
            c_array("NAME_point_gamma", core.point_gamma) if local else "",
            _QUERY,
            _NEIGHBOURS if local else "",
        ]
    )
    structure = "Set Membership + linear part" if model.linear_part else "Set Membership"
    notes = [
        f"{structure} NARX: f_u(w) = min_k (y_k + gamma ||w.*weights - W_k||) + epsilon,",
        "f_l(w) = max_k (y_k - gamma ||w.*weights - W_k||) - epsilon over the data set",
        f"({int(points.shape[0])} points, kd-tree of {int(start.shape[0])} nodes, the exact"
        " bounds: no point that changes a bound is skipped);",
        "lower = linear + f_l, upper = linear + f_u, y = linear + (f_l + f_u) / 2 (the central",
        "estimate, fed back), linear = intercept + coef' w (zero without a linear part)",
    ]
    if local:
        notes += [
            "Local constants: point k bounds with max(gamma(w), gamma_k), gamma(w) the largest",
            f"gamma_k of the {int(core.local_neighbours)} training points nearest w (ties"
            " included; the global gamma where rounding crosses the bounds)",
        ]
    return constants, _LOCAL_MAP if local else _MAP, notes


def c_set_membership(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.SetMembership` (``sm``, ``sm-linear``)."""
    constants, map_code, notes = sm_map_parts(model)
    structure = "Set Membership + linear part" if model.linear_part else "Set Membership"
    title = f"{structure} (neckid SetMembership)"
    return narx_model(model, title, notes, constants, map_code, bounded=True)
