r"""A fitted model as a plain description: its structure, coefficients, channels, lags and units.

:func:`export_model` gives one dictionary per model, the same keys for every model (the
*header*) and the family's own under ``"parameters"``; the documentation page
``docs/export.md`` lists every key and what it means. The writers of :mod:`neckid.export.files`
turn it into JSON, a MATLAB ``.mat`` file or a MATLAB script.

Values are plain: ``dict``, ``list``, ``str``, ``int``, ``float``, ``bool``, ``None`` and NumPy
arrays. A NumPy array holds numbers (a matrix, a vector); a ``list`` is a collection (channel
names, one array per channel or per input/output pair, the steps of the preprocessing, the
predictors of a multi-step model). Every key is a valid MATLAB field name of at most 31
characters, so the ``.mat`` file keeps the same names.

Each family is described from the model's public fitted attributes (``coef_``, ``lags_``,
``core_``, ...) by one function (``describe_arx``, ``describe_set_membership``, ...), named by its
method's registry entry (:attr:`neckid.registry.Method.describer`) and found through the
model's class and its bases; a new family adds one function and names it in its entry.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from neckid._version import __version__
from neckid.models.base import check_is_fitted
from neckid.utils.types import FloatArray, IntArray

__all__ = ["EXPORT_FORMAT", "EXPORT_VERSION", "LINEAR_CLASSES", "export_model", "is_linear"]

#: The ``"format"`` of every description.
EXPORT_FORMAT = "neckid-export"

#: The ``"format_version"``: raised when a key changes meaning or disappears (new keys do not).
EXPORT_VERSION = 1

#: Classes whose model is a linear time-invariant system (a transfer function exists).
LINEAR_CLASSES = ("LinearARX", "RecursiveARX", "SubspaceStateSpace")


def _array(value: Any) -> FloatArray:
    """A float64 copy of ``value`` (never a view into the model)."""
    return np.array(value, dtype=np.float64)


def _class_names(model: Any) -> list[str]:
    return [cls.__name__ for cls in type(model).__mro__]


def is_linear(model: Any) -> bool:
    """Whether ``model`` is linear time-invariant (one of :data:`LINEAR_CLASSES` or a subclass)."""
    return any(name in LINEAR_CLASSES for name in _class_names(model))


# ============================================================================ header
def _regressor(model: Any) -> dict[str, Any] | None:
    """The regressor terms (what rows of a coefficient matrix multiply), or None."""
    lags = model.fitted_lags()
    if lags is None:
        return None
    names = (lags.output_names, lags.input_names)
    return {
        "terms": list(lags.names),
        "source": ["output" if s == 0 else "input" for s in lags.source],
        "channel": [names[int(s)][int(c)] for s, c in zip(lags.source, lags.channel, strict=True)],
        "lag": np.array(lags.lag, dtype=np.int64),
        "conditions": list(lags.conditions),
    }


def _channel_lags(model: Any, source: int) -> list[IntArray] | None:
    """Per channel (outputs: ``source`` 0, inputs: 1), its lags in the regressor [samples]."""
    lags = model.fitted_lags()
    if lags is None:
        return None
    n_channels = len(lags.output_names if source == 0 else lags.input_names)
    mine = lags.source == source
    return [
        np.array(lags.lag[mine & (lags.channel == k)], dtype=np.int64) for k in range(n_channels)
    ]


def _ranges(box: dict[str, tuple[float, float]], names: Any) -> FloatArray:
    """``[low, high]`` per name (rows), NaN for a name without a recorded range."""
    rows = [box.get(name, (math.nan, math.nan)) for name in names]
    return np.array(rows, dtype=np.float64).reshape(len(rows), 2)


def _units(model: Any, kind: str) -> list[str]:
    """The unit of every input or output channel (``""`` where the model recorded none)."""
    names = model.input_names_ if kind == "input" else model.output_names_
    units = list((model.input_units_ if kind == "input" else model.output_units_) or ())
    return [str(u) for u in units] if len(units) == len(names) else [""] * len(names)


def _header(model: Any) -> dict[str, Any]:
    """The keys every description has, before ``parameters`` and ``transfer_function``."""
    from neckid.registry import method_of

    method = method_of(model)
    training = model.training_box()
    regressor = _regressor(model)
    terms = model.regressor_box()
    n_samples = model.training_samples()
    return {
        "model_class": type(model).__name__,
        "method": None if method is None else method.name,
        "label": None if method is None else method.label,
        "linear": is_linear(model),
        "ts": float(model.ts_),
        "input_names": list(model.input_names_),
        "output_names": list(model.output_names_),
        "input_units": _units(model, "input"),
        "output_units": _units(model, "output"),
        "max_lag": int(model.max_lag_),
        "n_samples": None if n_samples is None else int(n_samples),
        "regressor": regressor,
        "output_lags": _channel_lags(model, 0),
        "input_lags": _channel_lags(model, 1),
        "input_ranges": _ranges(training, model.input_names_),
        "output_ranges": _ranges(training, model.output_names_),
        "regressor_ranges": (
            None if regressor is None or not terms else _ranges(terms, regressor["terms"])
        ),
    }


def _describe(model: Any) -> dict[str, Any]:
    """Header, structure, parameters and transfer function (no file-level keys)."""
    describer = _describer(model)
    if describer is None:
        raise TypeError(
            f"export_model takes a fitted neckid model ({', '.join(_described_classes())}); got a"
            f" {type(model).__name__}"
        )
    check_is_fitted(model)
    structure, parameters = describer(model)
    description = _header(model)
    description["structure"] = structure
    description["parameters"] = parameters
    description["transfer_function"] = _transfer_function(model) if is_linear(model) else None
    return description


def export_model(model: Any) -> dict[str, Any]:
    r"""A fitted model as a plain, documented description (the contract of ``neckid export``).

    Parameters
    ----------
    model : fitted estimator
        Any model of :func:`neckid.methods` (``arx``, ``rls``, ``ss``, ``poly``, ``nn``,
        ``sm``, ``sm-linear``, ``sm-parallel``, ``sm-parallel-poly``, ``sm-multistep``,
        ``scheduled``), fitted or loaded with :func:`neckid.load_model`.

    Returns
    -------
    dict
        ``format`` (``"neckid-export"``), ``format_version``, ``neckid_version``,
        ``model_class``, ``method`` and ``label`` (the registry's), ``structure`` (``"arx"``,
        ``"state_space"``, ``"polynomial_narx"``, ``"neural_narx"``, ``"set_membership"``,
        ``"set_membership_parallel"``, ``"set_membership_multistep"``, ``"gain_scheduled"``),
        ``linear``, ``ts`` [s], ``input_names``, ``output_names``, ``input_units``,
        ``output_units``,
        ``max_lag`` and ``n_samples`` [samples], ``regressor`` (its ``terms`` with ``source``,
        ``channel`` and ``lag``), ``output_lags`` and ``input_lags`` (per channel, samples),
        ``input_ranges``, ``output_ranges`` and ``regressor_ranges`` (training ``[low,
        high]`` rows), ``preprocessing`` (the steps stored in the model), ``parameters`` (the
        family's coefficients, with an ``equation`` saying what each one means) and
        ``transfer_function`` (linear models; ``None`` otherwise). ``docs/export.md`` describes
        every key. Numbers are NumPy arrays; lists are collections.

    Raises
    ------
    NotFittedError
        Before ``fit``.
    TypeError
        If ``model`` is not a neckid model.

    Notes
    -----
    ARX polynomials follow MATLAB's ``idpoly``: :math:`A(q)\,y(t) = B(q)\,u(t) + c`,
    ``A{o, c} = [δ_oc, a_1, …, a_na]`` and ``B{o, j} = [0, …, 0, b_nk, …]`` in powers of
    :math:`q^{-1}` (leading zeros for the delay :math:`n_k`). The transfer function is
    :func:`neckid.export.control.to_control`'s, in descending powers of :math:`z`, without the
    output offset ``output_offset`` (:math:`y(t) = y_0 + G(q)\,u(t)`).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX, export_model
    >>> u = np.random.default_rng(0).normal(size=300)
    >>> y = np.zeros(300)
    >>> for t in range(2, 300):
    ...     y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 2]
    >>> data = IOData(u, y, ts=0.02, input_names=["cmd"], output_names=["incl"])
    >>> arx = LinearARX(Lags.arx(1, 1, delay=2), fit_intercept=False).fit(data)
    >>> description = export_model(arx)
    >>> description["structure"], description["ts"], description["input_lags"]
    ('arx', 0.02, [array([2])])
    >>> A, B = description["parameters"]["A"], description["parameters"]["B"]
    >>> np.round(A[0][0], 6), np.round(B[0][0], 6)
    (array([ 1. , -0.9]), array([0. , 0. , 0.5]))
    >>> tf = description["transfer_function"]
    >>> np.round(tf["num"][0][0], 6), np.round(tf["den"][0][0], 6)
    (array([0.5]), array([ 1. , -0.9,  0. ]))
    """
    description = {
        "format": EXPORT_FORMAT,
        "format_version": EXPORT_VERSION,
        "neckid_version": __version__,
        **_describe(model),
    }
    pipeline = model.preprocessing_
    description["preprocessing"] = [] if pipeline is None else list(pipeline.to_list())
    return description


# ============================================================================ linear models
def _transfer_function(model: Any) -> dict[str, Any]:
    """``num{o, j}``, ``den{o, j}`` (descending powers of z) and the output offset."""
    from neckid.export.control import output_offset, to_control

    system = to_control(model, form="tf")
    n_out, n_in = len(model.output_names_), len(model.input_names_)
    if "SubspaceStateSpace" in _class_names(model):
        offset = _array(model.intercept_)
    else:
        try:
            offset = _array(output_offset(model))
        except ValueError:  # a pole at z = 1: the intercept is a drift, not an offset
            offset = np.full(n_out, math.nan)
    return {
        "equation": "y(t) = output_offset + G(q) u(t); G{o,j}(z) = num{o,j}(z) / den{o,j}(z),"
        " coefficients in descending powers of z (MATLAB tf(num, den, ts))",
        "variable": "z",
        "num": [[_array(system.num[o][j]) for j in range(n_in)] for o in range(n_out)],
        "den": [[_array(system.den[o][j]) for j in range(n_in)] for o in range(n_out)],
        "output_offset": offset,
    }


def _arx_polynomials(model: Any) -> dict[str, Any]:
    """``A{o, c}`` and ``B{o, j}`` in powers of q^-1 (MATLAB ``idpoly``) and the ARX orders."""
    lags = model.lags_
    coef = np.asarray(model.coef_, dtype=np.float64).reshape(lags.n_terms, -1)
    n_out, n_in = len(lags.output_names), len(lags.input_names)
    outputs, inputs = lags.source == 0, lags.source == 1
    a_len = int(lags.lag[outputs].max(initial=0)) + 1
    b_len = int(lags.lag[inputs].max(initial=0)) + 1
    a = np.zeros((n_out, n_out, a_len))
    b = np.zeros((n_out, n_in, b_len))
    a[np.arange(n_out), np.arange(n_out), 0] = 1.0
    for j in range(lags.n_terms):
        c, lag = int(lags.channel[j]), int(lags.lag[j])
        if lags.source[j] == 0:
            a[:, c, lag] -= coef[j]
        else:
            b[:, c, lag] += coef[j]
    na = np.zeros((n_out, n_out), dtype=np.int64)
    nb = np.zeros((n_out, n_in), dtype=np.int64)
    nk = np.zeros((n_out, n_in), dtype=np.int64)
    for c in range(n_out):
        na[:, c] = int(lags.lag[outputs & (lags.channel == c)].max(initial=0))
    for c in range(n_in):
        used = lags.lag[inputs & (lags.channel == c)]
        if used.size:
            nk[:, c] = int(used.min())
            nb[:, c] = int(used.max()) - int(used.min()) + 1
    return {
        "A": [[a[o, c].copy() for c in range(n_out)] for o in range(n_out)],
        "B": [[b[o, c].copy() for c in range(n_in)] for o in range(n_out)],
        "na": na,
        "nb": nb,
        "nk": nk,
    }


_ARX_EQUATION = (
    "y(t) = intercept + coef' w(t), w(t) the regressor terms; in MATLAB's idpoly form"
    " A(q) y(t) = B(q) u(t) + intercept, A{o,c} = [1 a1 ... a_na] (0 off the diagonal) and"
    " B{o,j} = [0 ... 0 b_nk ...] in powers of q^-1"
)


def describe_arx(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted LinearARX (its registry entry's describer)."""
    return "arx", {
        "equation": _ARX_EQUATION,
        "coef": _array(model.coef_),
        "intercept": _array(model.intercept_),
        **_arx_polynomials(model),
    }


def describe_rls(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted RecursiveARX (its registry entry's describer)."""
    structure, parameters = describe_arx(model)
    parameters["equation"] += (
        "; estimated by CFF-RLS: theta = [a; b] with y(t) = theta' phi(t-1), phi ="
        " [-y(t-1) ...; u(t-d) ...]: the final estimate"
    )
    parameters["theta"] = _array(model.theta_)
    parameters["parameter_names"] = list(model.parameter_names_)
    parameters["forgetting_factor"] = float(model.forgetting_factor)
    return structure, parameters


def describe_subspace(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted SubspaceStateSpace (its registry entry's describer)."""
    return "state_space", {
        "equation": "x(t+1) = A x(t) + B u(t) + K e(t); y(t) = C x(t) + D u(t) + intercept"
        " + e(t) (innovation form; the free run has e = 0 and starts from the state that fits"
        " the first max_lag samples)",
        "A": _array(model.A_),
        "B": _array(model.B_),
        "C": _array(model.C_),
        "D": _array(model.D_),
        "K": _array(model.kalman_gain_),
        "intercept": _array(model.intercept_),
        "order": int(model.order_),
        "horizon": int(model.horizon_),
        "singular_values": _array(model.singular_values_),
    }


# ============================================================================ nonlinear NARX
def _monomial_names(powers: IntArray, terms: list[str]) -> list[str]:
    """``1``, ``z1``, ``z1^2*z2``: the monomials of the standardised terms ``z_k``."""
    names = []
    for row in powers:
        factors = [
            f"z{k + 1}" if p == 1 else f"z{k + 1}^{int(p)}" for k, p in enumerate(row) if p > 0
        ]
        names.append("*".join(factors) or "1")
    return names


def describe_polynomial(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted PolynomialNARX (its registry entry's describer)."""
    powers = np.array(model.powers_, dtype=np.int64)
    return "polynomial_narx", {
        "equation": "y_o(t) = sum_m coef(m, o) prod_k x_k^powers(m, k); x_k = (w_k - center_k)"
        " / scale_k, held in [low_k, high_k] inside the monomials of degree >= 2 (the degree-1"
        " terms use x_k as it is); monomials names row m with z_k for x_k",
        "degree": int(model.degree),
        "powers": powers,
        "monomials": _monomial_names(powers, list(model.lags_.names)),
        "coef": _array(model.coef_),
        "active": np.array(model.active_, dtype=bool),
        "center": _array(model.center_),
        "scale": _array(model.scale_),
        "low": _array(model.low_),
        "high": _array(model.high_),
    }


def describe_neural(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted NeuralNARX (its registry entry's describer)."""
    last = len(model.coefs_) - 1
    layers = [
        {
            "weights": _array(weights),
            "biases": _array(biases),
            "activation": "identity" if k == last else str(model.activation),
        }
        for k, (weights, biases) in enumerate(zip(model.coefs_, model.intercepts_, strict=True))
    ]
    return "neural_narx", {
        "equation": "y = y_mean + y_scale .* mean over networks m of f_m((w - x_mean) ./"
        " x_scale); f_m: h_0 = x, h_k = g_k(h_{k-1} W_k(m) + b_k(m)), W_k(m) ="
        " layers{k}.weights(m, :, :), b_k(m) = layers{k}.biases(m, :), g_k its activation",
        "activation": str(model.activation),
        "n_networks": int(model.coefs_[0].shape[0]),
        "x_mean": _array(model.x_mean_),
        "x_scale": _array(model.x_scale_),
        "y_mean": _array(model.y_mean_),
        "y_scale": _array(model.y_scale_),
        "layers": layers,
    }


# ============================================================================ Set Membership
_SM_EQUATION = (
    "f_u(w) = min_k (r_k + epsilon + gamma ||(w - W_k) .* weights||), f_l(w) = max_k (r_k -"
    " epsilon - gamma ||(w - W_k) .* weights||), r_k = outputs_k - (coef' W_k + intercept);"
    " bounds coef' w + intercept + [f_l, f_u], central estimate their mean (Milanese & Novara,"
    " 2004); with lipschitz = 'local', row k bounds with max(gamma(w), point_gamma_k) in place"
    " of gamma, gamma(w) the largest point_gamma of the local_neighbours rows nearest w"
)


def describe_set_membership(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted SetMembership (its registry entry's describer)."""
    core = model.core_
    curve = model.gamma_curve_
    point_gamma = model.point_gamma_
    return "set_membership", {
        "equation": _SM_EQUATION,
        "regressors": _array(core.x_train),
        "outputs": _array(core.y_train),
        "epsilon": _array(model.epsilon_),
        "gamma": _array(model.gamma_),
        "gamma_star": _array(model.gamma_star_),
        "prior_valid": np.array(model.prior_valid_, dtype=bool),
        "weights": _array(model.weights_),
        "linear_part": bool(model.linear_part),
        "coef": _array(model.coef_),
        "intercept": _array(model.intercept_),
        "lipschitz": "global" if point_gamma is None else "local",
        "point_gamma": None if point_gamma is None else _array(point_gamma),
        "local_neighbours": int(model.local_neighbours_),
        "gamma_curve": None
        if curve is None
        else {"epsilon": _array(curve.epsilons), "gamma_star": _array(curve.gamma)},
    }


def describe_parallel(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted ParallelSetMembership (its registry entry's describer)."""
    return "set_membership_parallel", {
        "equation": "y_L = free run of parallel_model on u; y(t) = the SM map (sm_map) at v(t) ="
        " [u(t - input_lags), y_L(t - linear_lags)], its inputs named <output>_linear for y_L;"
        " estimate 'central' or 'projection' (parallel model's output clipped to the bounds)",
        "estimate": str(model.estimate),
        "linear_lags": np.array(list(model.linear_lags), dtype=np.int64),
        "input_lags": np.array(list(model.input_lags), dtype=np.int64),
        "parallel_model": _describe(model.linear_),
        "sm_map": _describe(model.sm_),
    }


def describe_multistep(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted MultiStepSetMembership (its registry entry's describer)."""
    return "set_membership_multistep", {
        "equation": "y(t + k) = f_k(regressor of predictors{i}) for k = horizons(i), each an SM"
        " model on its own regressor; the free run chains them in blocks of horizon samples",
        "horizon": int(model.horizon),
        "horizons": np.array(model.horizons_, dtype=np.int64),
        "epsilon": _array(model.epsilon_),
        "gamma": _array(model.gamma_),
        "gamma_star": _array(model.gamma_star_),
        "residual_scale": _array(model.residual_scale_),
        "predictors": [_describe(sub) for sub in model.estimators_],
    }


# ============================================================================ scheduled
def describe_scheduled(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted GainScheduledModel (its registry entry's describer)."""
    delay = int(model.delay_)
    lags = model.lags_
    command = lags.input_names[int(lags.channel[lags.source == 1][0])]
    if model.form == "position":
        equation = f"i(t) = P(s) i(t-1) + N(s) u(t-{delay})"
    else:
        equation = f"r(t) = P(s) r(t-1) + N(s) u(t-{delay}); i(t) = i(t-1) + ts r(t)"
    return "gain_scheduled", {
        "equation": equation + f"; u = {command}, i the inclination [deg], s = i(t-1) clipped"
        " to schedule_range; N(s) = polyval(gain_coefficients, s), P(s) ="
        " polyval(pole_coefficients, s) held in [-pole_bound, pole_bound]",
        "form": str(model.form),
        "command": command,
        "delay": delay,
        "degree": int(np.size(model.gain_coefficients_)) - 1,
        "gain_coefficients": _array(model.gain_coefficients_),
        "pole_coefficients": _array(model.pole_coefficients_),
        "schedule_range": _array(model.schedule_range_),
        "pole_bound": float(model.pole_bound),
        "points": {
            "inclinations": _array(model.inclinations_),
            "gains": _array(model.gains_),
            "poles": _array(model.poles_),
        },
        "gain_rmse": float(model.gain_rmse_),
        "pole_rmse": float(model.pole_rmse_),
    }


# ============================================================================ grey box
def describe_greybox(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted GreyBoxNeck (its registry entry's describer)."""
    return "greybox_neck", {
        "equation": "s_j = play(x_j, slack_j / 2); v_o(t) = sum_jk (W{o}(jk) + sum_c W_c{o}(jk)"
        " p_c) play(s_j, radii(j, k))(t) + sum_c q{o}(c) p_c + offset{o}; y_o(t) = -sum_i"
        " A{o}(i+1) y_o(t-i) + sum(A{o}) v_o(t-delay); play(x, r)(t) = max(x(t) - r, min(x(t) + r,"
        " z(t-1))), z(-1) = x(0); weights columns: plays (j major), plays times each condition,"
        " conditions, 1 (see neckid.models.greybox)",
        "slack": _array(model.slack_),
        "radii": _array(model.radii_),
        "A": _array(model.denominators_),
        "reflection": _array(model.reflection_),
        "weights": _array(model.weights_),
        "delay": int(model.delay),
        "n_conditions": int(model.n_conditions_),
    }


def describe_greybox_ode(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted GreyBoxODE (its registry entry's describer)."""
    structure = model.structure_
    step = (
        "dx/dt = f(x, u, p) integrated by classical Runge-Kutta, substeps steps per sample,"
        " input held"
        if structure.time == "continuous"
        else "x(t+1) = f(x(t), u(t), p)"
    )
    return "greybox_ode", {
        "equation": f"grey-box structure {structure.name!r}: {step}, then the structure's"
        " saturation; y(t) = g(x(t), u(t), p); f, g and the saturation are the structure's"
        " functions (neckid.models.greybox); p in the order of parameter_names",
        "structure_name": structure.name,
        "parameter_names": list(structure.parameter_names),
        "parameter_units": [p.unit for p in structure.parameters],
        "parameter_values": _array(model.parameters_),
        "state_names": list(structure.state_names),
        "initial_states": _array(model.initial_states_),
        "substeps": int(model.substeps_),
    }


def describe_pnlss(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted PolynomialStateSpace (its registry entry's describer)."""
    names = [f"x{k + 1}" for k in range(int(model.order_))] + list(model.input_names_)
    a, b, c, d, intercept, e, f = model.matrices_
    return "polynomial_state_space", {
        "equation": "x(t+1) = A x + B v + E zeta(x, v); w(t) = C x + D v + intercept + F zeta(x,"
        " v), v = (u - u_center) ./ u_scale, y = y_center + y_scale .* w; zeta: the monomials"
        " (powers rows, over [x; v]) of z = ([x; v] - center) ./ scale held in [low, high]; the"
        " free run starts from the state start_A ... start_intercept fit to the first max_lag"
        " samples",
        "A": _array(a),
        "B": _array(b),
        "C": _array(c),
        "D": _array(d),
        "E": _array(e),
        "F": _array(f),
        "intercept": _array(intercept),
        "monomials": _monomial_names(model.powers_, names),
        "powers": np.asarray(model.powers_, dtype=np.int64),
        "u_center": _array(model.u_center_),
        "u_scale": _array(model.u_scale_),
        "y_center": _array(model.y_center_),
        "y_scale": _array(model.y_scale_),
        "center": _array(model.center_),
        "scale": _array(model.scale_),
        "low": _array(model.low_),
        "high": _array(model.high_),
        "start_A": _array(model.start_A_),
        "start_B": _array(model.start_B_),
        "start_C": _array(model.start_C_),
        "start_D": _array(model.start_D_),
        "start_intercept": _array(model.start_intercept_),
        "order": int(model.order_),
    }


Describer = Callable[[Any], tuple[str, dict[str, Any]]]


def _describer(model: Any) -> Describer | None:
    """The function describing ``model``: its method's :attr:`~neckid.registry.Method.describer`.

    Found through the model's class and its bases (a subclass of a registered class is described
    as that class); ``None`` for an object of no registered class.
    """
    from neckid.registry import methods

    by_class = {m.class_name: m.describer for m in methods().values() if m.describer}
    name = next((by_class[n] for n in _class_names(model) if n in by_class), None)
    if name is None:
        return None
    module, _, function = name.partition(":")
    describer: Describer = getattr(importlib.import_module(module), function)
    return describer


def _described_classes() -> list[str]:
    from neckid.registry import methods

    return sorted({m.class_name for m in methods().values() if m.describer})
