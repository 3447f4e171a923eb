r"""python-control interop: identified models as transfer functions and as I/O systems.

* :func:`to_control` turns a *linear* model (:class:`~neckid.LinearARX`,
  :class:`~neckid.RecursiveARX`, or a :class:`~neckid.GainScheduledModel` frozen at one
  inclination) into a discrete ``control.TransferFunction`` (or ``StateSpace``) with
  ``dt = ts_`` and the model's channel names, for Bode plots, margins and controller design.
* :func:`to_iosystem` turns *any* fitted model (and the loop's other pieces: an
  :class:`~neckid.plant.InclinationController`, a
  :class:`~neckid.loops.model_in_loop.VelocityDrive`) into a discrete
  ``control.NonlinearIOSystem`` that ``control.interconnect`` can wire to a user's controller.

Time alignment (the same in neckid and in python-control)
---------------------------------------------------------
``control.input_output_response`` on a discrete system computes, for ``k = 0, 1, …``,
``y[k] = outfcn(t_k, x[k], u[k])`` and then ``x[k+1] = updfcn(t_k, x[k], u[k])``: the output of
sample ``k`` is returned *with* the input of sample ``k``, exactly as a neckid simulator's
``step(u(t)) -> y(t)``. A model with an input lag of 0 (``u(t)`` in its regressor) has direct
feedthrough, and its output function reads ``u[k]``; with every input lag >= 1 the output depends
on the state alone. :func:`~neckid.plant.closed_loop` computes command ``k`` from output
``k − 1``; the controller's I/O system does the same by holding the last measurement in its
state, so it has no feedthrough from the measurement and a loop never has an algebraic loop.

State of a model's I/O system
-----------------------------
The state is the simulator's history, oldest row first, ``m = max(max_lag_, 1)`` rows each:
``x = [y(t−m), …, y(t−1), u(t−m), …, u(t−1)]`` (rows flattened, channel by channel). The update
and output functions rebuild the simulator from ``x`` at every call (``reset(y0, u0)`` then
``step(u)``), so they are pure functions of ``(t, x, u)`` as python-control requires, and they
reproduce ``model.simulate`` to the last bit. :func:`initial_state` packs initial conditions.
Three models keep something else: :class:`~neckid.ParallelSetMembership` keeps its linear part's
*simulated* outputs (``<output>_linear``); :class:`~neckid.GainScheduledModel` keeps
``[i(t−1), r(t−1), u(t−d), …, u(t−1)]`` (inclination [deg], its rate [deg/s], the last ``d``
commands); :class:`~neckid.models.set_membership.multistep.MultiStepSetMembership` keeps the anchor of its
chained free run, the inputs since and the number of steps since, and replays them (up to
``horizon`` model evaluations per sample).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

import control
import numpy as np
from numpy.typing import ArrayLike

from neckid._typing import FloatArray
from neckid.loops.model_in_loop import POSITION, VELOCITY, VelocityDrive, channel_names
from neckid.models.base import Estimator, check_is_fitted, history_rows
from neckid.models.linear.arx import LinearARX
from neckid.models.linear.rls import RecursiveARX
from neckid.models.scheduled.model import GainScheduledModel
from neckid.models.set_membership.multistep import MultiStepSetMembership
from neckid.models.set_membership.parallel import LINEAR_SUFFIX, ParallelSetMembership
from neckid.plant.control import InclinationController
from neckid.validation import check_finite

__all__ = ["initial_state", "output_offset", "to_control", "to_iosystem"]


LINEAR_MODELS = (LinearARX, RecursiveARX, GainScheduledModel)


# ============================================================================ linear models
def _linear_parts(model: Any) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(A, B, intercept)``: ``A[l]`` (n_out, n_out) and ``B[l]`` (n_out, n_in) for lags 0..L.

    ``y(t) = intercept + sum_l A[l] y(t − l) + sum_l B[l] u(t − l)`` (``A[0]`` is zero).
    """
    lags = model.lags_
    coef = np.asarray(model.coef_, dtype=np.float64)
    n_out, n_in = len(lags.output_names), len(lags.input_names)
    top = int(lags.max_lag)
    a = np.zeros((top + 1, n_out, n_out))
    b = np.zeros((top + 1, n_out, n_in))
    for j in range(lags.n_terms):
        target = a if lags.source[j] == 0 else b
        target[lags.lag[j], :, lags.channel[j]] += coef[j]
    intercept = np.asarray(getattr(model, "intercept_", np.zeros(n_out)), dtype=np.float64)
    return a, b, intercept


def output_offset(model: LinearARX | RecursiveARX) -> FloatArray:
    r"""The output the ARX model settles at with all inputs zero: its intercept as an offset.

    An ARX model with an intercept :math:`c`,
    :math:`y(t) = c + \sum_l A_l\,y(t-l) + \sum_l B_l\,u(t-l)`, is the transfer function of
    :func:`to_control` around the offset :math:`y_0 = (I - \sum_l A_l)^{-1} c`:
    :math:`y(t) = y_0 + G(q)\,u(t)` exactly (substitute and the constants cancel).

    Returns
    -------
    ndarray, shape (n_outputs,)
        :math:`y_0`, in the output units (zeros without an intercept).

    Raises
    ------
    ValueError
        If :math:`I - \sum_l A_l` is singular (an integrator): the intercept is then a drift, not
        an offset.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> from neckid.interop import output_offset
    >>> u = np.random.default_rng(0).normal(size=300)
    >>> y = np.zeros(300)
    >>> for t in range(1, 300):
    ...     y[t] = 1.0 + 0.5 * y[t - 1] + u[t - 1]
    >>> model = LinearARX(Lags.arx(1, 1)).fit(IOData(u, y, ts=0.02))
    >>> np.round(output_offset(model), 6)
    array([2.])
    """
    if not isinstance(model, LinearARX | RecursiveARX):
        raise TypeError(
            f"output_offset needs a LinearARX or RecursiveARX; got {type(model).__name__}"
        )
    check_is_fitted(model)
    a, _, intercept = _linear_parts(model)
    if not np.any(intercept):
        return np.zeros_like(intercept)
    static = np.eye(a.shape[1]) - a.sum(axis=0)
    condition = float(np.linalg.cond(static))
    if not condition < 1e12:
        raise ValueError(
            f"the {type(model).__name__} has a pole at z = 1 (I - sum of its output coefficients"
            f" has condition number {condition:.3g}): its intercept is a drift, not an output offset"
        )
    return np.asarray(np.linalg.solve(static, intercept), dtype=np.float64)


def _poly_det(matrix: list[list[FloatArray]]) -> FloatArray:
    """Determinant of a square matrix of polynomials (descending powers), by cofactors."""
    n = len(matrix)
    if n == 1:
        return matrix[0][0]
    total = np.zeros(1)
    for col in range(n):
        minor = [row[:col] + row[col + 1 :] for row in matrix[1:]]
        term = np.polymul(matrix[0][col], _poly_det(minor))
        total = np.polyadd(total, term) if col % 2 == 0 else np.polysub(total, term)
    return np.asarray(total, dtype=np.float64)


def _trim(num: FloatArray, den: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Drop exact common factors ``z`` (trailing zeros of both) and leading zeros of ``num``."""
    num = np.trim_zeros(num, "f")
    if num.size == 0:
        return np.zeros(1), np.ones(1)
    common = min(num.size - np.trim_zeros(num, "b").size, den.size - np.trim_zeros(den, "b").size)
    if common:
        num, den = num[:-common], den[:-common]
    return num, den


def _arx_transfer_function(model: Any, name: str | None) -> control.TransferFunction:
    a, b, _ = _linear_parts(model)
    n_out, n_in = b.shape[1], b.shape[2]
    # A(z) = z^L I - sum_l A_l z^(L-l), B(z) = sum_l B_l z^(L-l): descending powers of z.
    a_poly = [
        [np.array([float(o == c), *(-a[1:, o, c])]) for c in range(n_out)] for o in range(n_out)
    ]
    det = _poly_det(a_poly)
    nums: list[list[FloatArray]] = []
    dens: list[list[FloatArray]] = []
    for o in range(n_out):
        nums.append([])
        dens.append([])
        for j in range(n_in):
            # (adj A · B)_{o j} = sum_c (−1)^(o+c) det(minor(A, c, o)) · B_{c j}
            num = np.zeros(1)
            for c in range(n_out):
                if n_out == 1:
                    cofactor = np.ones(1)
                else:
                    minor = [row[:o] + row[o + 1 :] for r, row in enumerate(a_poly) if r != c]
                    cofactor = (-1.0) ** (o + c) * _poly_det(minor)
                num = np.polyadd(num, np.polymul(cofactor, b[:, c, j]))
            pair = _trim(np.asarray(num, dtype=np.float64), det.copy())
            nums[o].append(pair[0])
            dens[o].append(pair[1])
    return control.TransferFunction(
        nums,
        dens,
        dt=model.ts_,
        inputs=list(model.input_names_),
        outputs=list(model.output_names_),
        name=name or type(model).__name__,
    )


def _arx_state_space(model: Any, name: str | None) -> control.StateSpace:
    """The ARX in the state of :func:`to_iosystem`: ``x = [y history, u history]``."""
    a, b, _ = _linear_parts(model)
    n_out, n_in = b.shape[1], b.shape[2]
    m = max(a.shape[0] - 1, 1)
    n_y, n_x = m * n_out, m * (n_out + n_in)
    c_mat = np.zeros((n_out, n_x))
    d_mat = b[0].copy()
    for lag in range(1, a.shape[0]):
        row = m - lag  # history row of t − lag
        c_mat[:, row * n_out : (row + 1) * n_out] += a[lag]
        c_mat[:, n_y + row * n_in : n_y + (row + 1) * n_in] += b[lag]
    a_mat = np.zeros((n_x, n_x))
    b_mat = np.zeros((n_x, n_in))
    for start, width, block in ((0, n_out, n_y), (n_y, n_in, n_x - n_y)):
        shift = np.eye(block, k=width)  # rows move up by one history row
        a_mat[start : start + block, start : start + block] = shift
    a_mat[n_y - n_out : n_y] = c_mat
    b_mat[n_y - n_out : n_y] = d_mat
    b_mat[n_x - n_in :] = np.eye(n_in)
    states = _history_names(model.output_names_, m) + _history_names(model.input_names_, m)
    return control.StateSpace(
        a_mat,
        b_mat,
        c_mat,
        d_mat,
        dt=model.ts_,
        inputs=list(model.input_names_),
        outputs=list(model.output_names_),
        states=states,
        name=name or type(model).__name__,
    )


def _command_channel(model: GainScheduledModel) -> int:
    """Index of the scheduled model's command among its inputs (its one lagged input)."""
    return int(model.lags_.channel[model.lags_.source == 1][0])


def _scheduled_frozen(
    model: GainScheduledModel, inclination: float, form: str, name: str | None
) -> control.TransferFunction | control.StateSpace:
    command = model.input_names_[_command_channel(model)]
    output = model.output_names_[0]
    label = name or f"{type(model).__name__}@{inclination:g}deg"
    if form == "tf":
        frozen = model.transfer_function(inclination, to="inclination")
        return control.TransferFunction(
            frozen.num, frozen.den, dt=model.ts_, inputs=[command], outputs=[output], name=label
        )
    gain = float(model.gain(inclination))
    pole = float(model.pole(inclination))
    ts, d = model.ts_, model.delay_
    n_x = 2 + d
    c_mat = np.zeros((1, n_x))
    a_mat = np.zeros((n_x, n_x))
    if getattr(model, "form", "rate") == "position":
        # i(t) = P i(t−1) + N x(t−d); r(t) = (i(t) − i(t−1)) / ts, kept as a state for the names.
        c_mat[0, [0, 2]] = [pole, gain]
        a_mat[0] = c_mat[0]
        a_mat[1, 0], a_mat[1, 2] = (pole - 1.0) / ts, gain / ts
    else:
        c_mat[0, :3] = [1.0, ts * pole, ts * gain]  # i(t) = i(t−1) + ts (P r(t−1) + N u(t−d))
        a_mat[0] = c_mat[0]
        a_mat[1, 1], a_mat[1, 2] = pole, gain  # r(t) = P r(t−1) + N u(t−d)
    a_mat[2:, 2:] = np.eye(d, k=1)
    b_mat = np.zeros((n_x, 1))
    b_mat[-1, 0] = 1.0
    return control.StateSpace(
        a_mat,
        b_mat,
        c_mat,
        np.zeros((1, 1)),
        dt=ts,
        inputs=[command],
        outputs=[output],
        states=_scheduled_state_names(model),
        name=label,
    )


def to_control(
    model: Any,
    *,
    inclination: float | None = None,
    form: Literal["tf", "ss"] = "tf",
    strict: bool = False,
    name: str | None = None,
) -> Any:
    r"""A linear model as a discrete python-control system (``dt = ts_``, channels named).

    Parameters
    ----------
    model : LinearARX, RecursiveARX or GainScheduledModel
        Fitted. ARX models: from every input to every output (MIMO when there are several).
        ``RecursiveARX``: its final estimate ``coef_``. ``GainScheduledModel``: frozen at
        ``inclination``, from the velocity command [rad/s] to the inclination [deg]
        (:meth:`~neckid.GainScheduledModel.transfer_function` with ``to="inclination"``).
    inclination : float, optional
        Operating point [deg]; required for a ``GainScheduledModel``, refused otherwise.
    form : {"tf", "ss"}, default "tf"
        ``"tf"``: a ``control.TransferFunction``. ``"ss"``: a ``control.StateSpace`` whose state
        is the one of :func:`to_iosystem` (so ``X0 = initial_state(model, y0, u0)`` starts it
        from given initial conditions, and a MIMO model simulates without slycot).
    strict : bool, default False
        Refuse a model with a non-zero intercept instead of leaving the intercept out.
    name : str, optional
        The system's name (default the class name).

    Returns
    -------
    control.TransferFunction or control.StateSpace

    Raises
    ------
    TypeError
        If the model is nonlinear (Set Membership, neural): use :func:`to_iosystem`.
    ValueError
        If ``inclination`` is missing for a scheduled model (or given for another), or
        ``strict`` and the model has an intercept.
    NotFittedError
        Before ``fit``.

    Notes
    -----
    For an ARX model :math:`A(q^{-1})\,y(t) = B(q^{-1})\,u(t) + c` the transfer function is
    :math:`G(z) = A(z)^{-1} B(z)` with :math:`A(z) = z^L I - \sum_l A_l z^{L-l}`,
    :math:`B(z) = \sum_l B_l z^{L-l}` and :math:`L` the largest lag (Ljung, *System
    Identification*, 2nd ed., 1999, sec. 4.2). With several outputs every element is
    :math:`(\mathrm{adj}\,A(z)\,B(z))_{oj} / \det A(z)`: a common denominator, not reduced
    (``control.minreal`` cancels what cancels). Exact common factors :math:`z` are dropped.

    The intercept :math:`c` is *not* part of :math:`G`: it is an output offset,
    :math:`y(t) = y_0 + G(q)\,u(t)` with :math:`y_0` = :func:`output_offset` (and the
    simulation started from :math:`y_0`). ``strict=True`` refuses a model with one.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> from neckid.interop import to_control
    >>> u = np.random.default_rng(0).normal(size=300)
    >>> y = np.zeros(300)
    >>> for t in range(1, 300):
    ...     y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    >>> data = IOData(u, y, ts=0.02, input_names=["motor_position"], output_names=["inclination"])
    >>> g = to_control(LinearARX(Lags.arx(1, 1), fit_intercept=False).fit(data))
    >>> np.round(g.num[0][0], 6), np.round(g.den[0][0], 6), g.dt, g.input_labels
    (array([0.5]), array([ 1. , -0.9]), 0.02, ['motor_position'])
    """
    if not isinstance(model, Estimator):
        raise TypeError(f"to_control takes a fitted neckid model; got {type(model).__name__}")
    check_is_fitted(model)
    if form not in ("tf", "ss"):
        raise ValueError(f"form must be 'tf' or 'ss'; got {form!r}")
    if isinstance(model, GainScheduledModel):
        if inclination is None:
            raise ValueError(
                "inclination is required for a GainScheduledModel: the operating point [deg] to"
                " freeze N(i) / (z - P(i)) at, e.g. to_control(model, inclination=20.0)"
            )
        return _scheduled_frozen(model, float(inclination), form, name)
    if not isinstance(model, LINEAR_MODELS):
        raise TypeError(
            f"to_control needs a linear model (LinearARX, RecursiveARX, GainScheduledModel); a"
            f" {type(model).__name__} is nonlinear: use neckid.interop.to_iosystem(model) for a"
            " control.NonlinearIOSystem"
        )
    if inclination is not None:
        raise ValueError(
            f"inclination applies to a GainScheduledModel only; got {inclination!r} for a"
            f" {type(model).__name__}"
        )
    _, _, intercept = _linear_parts(model)
    if strict and np.any(intercept):
        raise ValueError(
            f"the {type(model).__name__} has an intercept {intercept.tolist()}, which a transfer"
            " function cannot hold (it is the offset output_offset(model)); pass strict=False to"
            " leave it out, or fit with fit_intercept=False"
        )
    if form == "ss":
        return _arx_state_space(model, name)
    return _arx_transfer_function(model, name)


# ============================================================================ I/O systems
def _history_names(names: Sequence[str], m: int) -> list[str]:
    return [f"{n}[t-{m - r}]" for r in range(m) for n in names]


def _scheduled_state_names(model: GainScheduledModel) -> list[str]:
    output = model.output_names_[0]
    command = model.input_names_[_command_channel(model)]
    past = [f"{command}[t-{model.delay_ - k}]" for k in range(model.delay_)]
    return [f"{output}[t-1]", f"{output}_rate[t-1]", *past]


class _StateMap:
    """A one-step map on a packed state: ``output(x, u)`` and ``update(x, u)``, both pure.

    Subclasses give ``_output(x, u)`` and ``_next(x, u, out)``; ``feedthrough`` says whether the
    output reads ``u`` (when it does not, one evaluation per state serves every input).
    """

    inputs: list[str]
    outputs: list[str]
    states: list[str]
    ts: float
    feedthrough: bool = True

    #: Evaluations kept: python-control asks for the same few several times per sample.
    CACHE_SIZE = 4

    def __init__(self) -> None:
        self._cache: dict[tuple[bytes, bytes], FloatArray] = {}

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        raise NotImplementedError  # pragma: no cover - abstract

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        raise NotImplementedError  # pragma: no cover - abstract

    def output(self, x: ArrayLike, u: ArrayLike) -> FloatArray:
        """The outputs at state ``x`` and input ``u``."""
        x_arr = np.asarray(x, dtype=np.float64).reshape(-1)
        u_arr = np.asarray(u, dtype=np.float64).reshape(-1)
        key = (x_arr.tobytes(), u_arr.tobytes() if self.feedthrough else b"")
        if key not in self._cache:
            if len(self._cache) >= self.CACHE_SIZE:
                self._cache.pop(next(iter(self._cache)))
            self._cache[key] = self._output(x_arr, u_arr)
        return self._cache[key].copy()

    def update(self, x: ArrayLike, u: ArrayLike) -> FloatArray:
        """The state one sample later."""
        x_arr = np.asarray(x, dtype=np.float64).reshape(-1)
        u_arr = np.asarray(u, dtype=np.float64).reshape(-1)
        return self._next(x_arr, u_arr, self.output(x_arr, u_arr))

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        raise NotImplementedError  # pragma: no cover - abstract


def _has_lag_zero_input(lags: Any) -> bool:
    return bool(np.any((lags.source == 1) & (lags.lag == 0)))


class _HistoryMap(_StateMap):
    """Models whose simulator state is its last ``m`` outputs and inputs (the NARX models)."""

    def __init__(self, model: Any, bounds: bool) -> None:
        super().__init__()
        self._simulator = model.simulator()
        self._bounds = bounds and callable(getattr(self._simulator, "step_bounds", None))
        self.m = max(int(model.max_lag_), 1)
        self.n_out, self.n_in = len(model.output_names_), len(model.input_names_)
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        if self._bounds:
            self.outputs += [
                f"{n}_{side}" for side in ("lower", "upper") for n in model.output_names_
            ]
        self.states = self._state_names(model)
        self.ts = float(model.ts_)
        self.feedthrough = self._feedthrough(model)

    def _feedthrough(self, model: Any) -> bool:
        lags = getattr(model, "lags_", None)
        return lags is None or _has_lag_zero_input(lags)

    def _state_names(self, model: Any) -> list[str]:
        return _history_names(model.output_names_, self.m) + _history_names(
            model.input_names_, self.m
        )

    def _split(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        n_y = self.m * self.n_out
        return x[:n_y].reshape(self.m, self.n_out), x[n_y:].reshape(self.m, self.n_in)

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        y_hist, u_hist = self._split(x)
        self._simulator.reset(y0=y_hist, u0=u_hist)
        if self._bounds:
            return np.concatenate(self._simulator.step_bounds(u))
        return np.asarray(self._simulator.step(u), dtype=np.float64)

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        y_hist, u_hist = self._split(x)
        return np.concatenate([y_hist[1:].ravel(), out[: self.n_out], u_hist[1:].ravel(), u])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        y_hist = history_rows(y0, self.m, self.n_out, "y0")
        u_hist = history_rows(u0, self.m, self.n_in, "u0")
        return np.concatenate([y_hist.ravel(), u_hist.ravel()])


class _ParallelMap(_HistoryMap):
    """ParallelSetMembership: the history holds its linear part's *simulated* outputs."""

    def __init__(self, model: ParallelSetMembership, bounds: bool) -> None:
        super().__init__(model, bounds)
        self._linear = model.linear_.simulator()
        self._m_linear = max(int(model.linear_.max_lag_), 1)

    def _feedthrough(self, model: Any) -> bool:
        sm_lags = model.sm_.lags_
        measured = np.isin(sm_lags.channel, np.arange(len(model.input_names_)))
        direct = bool(np.any((sm_lags.source == 1) & (sm_lags.lag == 0) & measured))
        through_linear = bool(np.any((sm_lags.source == 1) & (sm_lags.lag == 0) & ~measured))
        return direct or (through_linear and _has_lag_zero_input(model.linear_.lags_))

    def _state_names(self, model: Any) -> list[str]:
        linear = [n + LINEAR_SUFFIX for n in model.output_names_]
        return _history_names(linear, self.m) + _history_names(model.input_names_, self.m)

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        y_hist, u_hist = self._split(x)
        self._simulator.reset(y0=y_hist, u0=u_hist)
        y, low, high = self._simulator.step_bounds(u)
        return np.concatenate([y, low, high]) if self._bounds else y

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        y_hist, u_hist = self._split(x)
        self._linear.reset(y_hist[-self._m_linear :], u_hist[-self._m_linear :])
        y_linear = np.asarray(self._linear.step(u), dtype=np.float64)
        return np.concatenate([y_hist[1:].ravel(), y_linear, u_hist[1:].ravel(), u])


class _MultiStepMap(_StateMap):
    """MultiStepSetMembership: the anchor of its chained free run and the inputs since.

    ``x = [k, y anchor (m rows), u anchor (m rows), u since the anchor (horizon − 1 rows)]``
    with ``k`` the steps taken since the anchor (rows past ``k`` are zero). The simulator is
    rebuilt by ``reset`` on the anchor and a replay of the ``k`` inputs (deterministic, so the
    same bits), then stepped: up to ``horizon`` evaluations per sample.
    """

    def __init__(self, model: MultiStepSetMembership, bounds: bool) -> None:
        super().__init__()
        self._simulator = model.simulator()
        self._bounds = bounds
        self.m = max(int(model.max_lag_), 1)
        self.block = int(model.horizon)
        self.n_out, self.n_in = len(model.output_names_), len(model.input_names_)
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        if bounds:
            self.outputs += [
                f"{n}_{side}" for side in ("lower", "upper") for n in model.output_names_
            ]
        since = [f"{n}[anchor+{j}]" for j in range(1, self.block) for n in model.input_names_]
        self.states = [
            "steps_since_anchor",
            *_history_names([f"{n}_anchor" for n in model.output_names_], self.m),
            *_history_names([f"{n}_anchor" for n in model.input_names_], self.m),
            *since,
        ]
        self.ts = float(model.ts_)
        self.feedthrough = any(_has_lag_zero_input(e.lags_) for e in model.estimators_)

    def _split(self, x: FloatArray) -> tuple[int, FloatArray, FloatArray, FloatArray]:
        n_y, n_u = self.m * self.n_out, self.m * self.n_in
        steps = round(float(x[0]))
        y_anchor = x[1 : 1 + n_y].reshape(self.m, self.n_out)
        u_anchor = x[1 + n_y : 1 + n_y + n_u].reshape(self.m, self.n_in)
        since = x[1 + n_y + n_u :].reshape(self.block - 1, self.n_in)
        return steps, y_anchor, u_anchor, since

    def _replay(self, x: FloatArray, u: FloatArray) -> tuple[list[FloatArray], FloatArray]:
        steps, y_anchor, u_anchor, since = self._split(x)
        self._simulator.reset(y0=y_anchor, u0=u_anchor)
        outputs = [
            np.asarray(self._simulator.step(since[j]), dtype=np.float64) for j in range(steps)
        ]
        y, low, high = self._simulator.step_bounds(u)
        outputs.append(np.asarray(y, dtype=np.float64))
        return outputs, np.concatenate([y, low, high]) if self._bounds else outputs[-1]

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        return self._replay(x, u)[1]

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        steps, y_anchor, u_anchor, since = self._split(x)
        since = since.copy()
        if steps + 1 < self.block:
            since[steps] = u
            return np.concatenate(
                [[steps + 1.0], y_anchor.ravel(), u_anchor.ravel(), since.ravel()]
            )
        outputs, _ = self._replay(x, u)
        y_rows = np.vstack([y_anchor, *outputs])[-self.m :]
        u_rows = np.vstack([u_anchor, since[:steps], u[None, :]])[-self.m :]
        return np.concatenate([[0.0], y_rows.ravel(), u_rows.ravel(), np.zeros(since.size)])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        y_hist = history_rows(y0, self.m, self.n_out, "y0")
        u_hist = history_rows(u0, self.m, self.n_in, "u0")
        return np.concatenate(
            [[0.0], y_hist.ravel(), u_hist.ravel(), np.zeros((self.block - 1) * self.n_in)]
        )


class _ScheduledMap(_StateMap):
    """GainScheduledModel: ``x = [i(t−1), r(t−1), u(t−d), …, u(t−1)]``; no feedthrough."""

    feedthrough = False

    def __init__(self, model: GainScheduledModel) -> None:
        super().__init__()
        self._model = model
        self._channel = _command_channel(model)
        self.delay = int(model.delay_)
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        self.states = _scheduled_state_names(model)
        self.ts = float(model.ts_)
        self._position = getattr(model, "form", "rate") == "position"

    def _advance(self, x: FloatArray) -> tuple[float, float]:
        incl, rate = float(x[0]), float(x[1])
        # The same operations, in the same order, as GainScheduledSimulator.step.
        gain = float(self._model.gain(incl))
        pole = float(self._model.pole(incl))
        if self._position:
            following = pole * incl + gain * float(x[2])
            return following, (following - incl) / self.ts
        rate = pole * rate + gain * float(x[2])
        return incl + self.ts * rate, rate

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        return np.array([self._advance(x)[0]])

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        check_finite(u[None, :], "u")
        incl, rate = self._advance(x)
        return np.array([incl, rate, *x[3:], u[self._channel]])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        # As GainScheduledSimulator.reset: the last row of each, at rest (rate 0).
        y_last = 0.0 if y0 is None else float(np.asarray(y0, dtype=np.float64).reshape(-1)[-1])
        u_rows = np.zeros(len(self.inputs)) if u0 is None else np.asarray(u0, dtype=np.float64)
        u_last = float(u_rows.reshape(-1, len(self.inputs))[-1, self._channel])
        state = np.array([y_last, 0.0, *([u_last] * self.delay)])
        check_finite(state[None, :], "initial state")
        return state


class _ControllerMap(_StateMap):
    """InclinationController: ``x = [integral, last measurement]``; feedthrough of the reference only."""

    def __init__(self, controller: InclinationController) -> None:
        super().__init__()
        self._controller = controller
        planar = controller.configuration == "planar"
        references = ["reference"] if planar else ["reference_inclination", "reference_orientation"]
        measured = ["inclination"] if planar else ["inclination", "orientation"]
        self.inputs = references + measured
        self.outputs = list(channel_names("velocity_command", controller.n_motors))
        integrals = ["integral"] if planar else ["integral_x", "integral_y"]
        self.states = integrals + [f"{n}[t-1]" for n in measured]
        self.ts = controller.ts
        self._n_int = controller.n_integrals
        self._n_ref = controller.n_references

    def _law(self, x: FloatArray, u: FloatArray) -> tuple[FloatArray, FloatArray]:
        return self._controller.control_law(x[: self._n_int], u[: self._n_ref], x[self._n_int :])

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        return self._law(x, u)[0]

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        return np.concatenate([self._law(x, u)[1], u[self._n_ref :]])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        return np.zeros(len(self.states))  # as after reset(), with a zero first measurement


class _DriveMap(_StateMap):
    """VelocityDrive: ``x = [position, velocity]``, output at the start of the sample."""

    feedthrough = False

    def __init__(self, drive: VelocityDrive) -> None:
        super().__init__()
        self._drive = drive
        n = drive.n_motors
        self.inputs = list(channel_names("velocity_command", n))
        self.outputs = list(channel_names(POSITION, n) + channel_names(VELOCITY, n))
        self.states = list(self.outputs)
        self.ts = drive.ts
        self._n = n

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        return x.copy()

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        position, velocity = self._drive.advance(x[: self._n], x[self._n :], u)
        return np.concatenate([position, velocity])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        return np.zeros(2 * self._n)


def _state_map(system: Any, bounds: bool = False) -> _StateMap:
    if isinstance(system, InclinationController):
        return _ControllerMap(system)
    if isinstance(system, VelocityDrive):
        return _DriveMap(system)
    if not isinstance(system, Estimator):
        raise TypeError(
            "to_iosystem takes a fitted neckid model, an InclinationController or a"
            f" VelocityDrive; got {type(system).__name__}"
        )
    check_is_fitted(system)
    if isinstance(system, GainScheduledModel):
        return _ScheduledMap(system)
    if isinstance(system, ParallelSetMembership):
        return _ParallelMap(system, bounds)
    if isinstance(system, MultiStepSetMembership):
        return _MultiStepMap(system, bounds)
    return _HistoryMap(system, bounds)


def to_iosystem(
    system: Any, *, name: str | None = None, bounds: bool = False
) -> control.NonlinearIOSystem:
    """Any fitted model (or the controller, or the drive) as a discrete python-control I/O system.

    Parameters
    ----------
    system : fitted estimator, InclinationController or VelocityDrive
        A model of :func:`neckid.methods`; or the loop's controller (inputs ``reference`` and
        ``inclination``, output ``velocity_command``; ``_1`` .. ``_3`` and orientation channels
        with three tendons); or the motor drive (input ``velocity_command``, outputs
        ``motor_position`` and ``motor_velocity``).
    name : str, optional
        The system's name (default the class name).
    bounds : bool, default False
        Set Membership models: add the outputs ``<output>_lower`` and ``<output>_upper`` (the
        step's bounds). Ignored for models without bounds.

    Returns
    -------
    control.NonlinearIOSystem
        Discrete (``dt = ts``), inputs and outputs named after the channels, so
        ``control.interconnect`` connects same-named signals by itself. Its state is described in
        the module docstring; :func:`initial_state` packs initial conditions.

    Raises
    ------
    TypeError
        If ``system`` is none of those.
    NotFittedError
        If the model is not fitted.

    Notes
    -----
    ``input_output_response(sys, T, U, X0)`` returns ``y[k]`` computed with ``u[k]`` (see the
    module docstring), so with ``X0 = initial_state(model, y[:m], u[:m])`` and ``U = u[m:]`` it
    equals ``model.simulate(data).y[m:]``. Each call of the update or output function rebuilds
    the simulator from the state (pure in ``(t, x, u)``); the last few evaluations are cached, since
    python-control asks for the same one several times per sample.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> from neckid.interop import initial_state, to_iosystem
    >>> u = np.random.default_rng(0).normal(size=200)
    >>> y = np.zeros(200)
    >>> for t in range(1, 200):
    ...     y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    >>> data = IOData(u, y, ts=0.02, input_names=["velocity_command"], output_names=["inclination"])
    >>> model = LinearARX(Lags.arx(1, 1), fit_intercept=False).fit(data)
    >>> system = to_iosystem(model)
    >>> system.input_labels, system.output_labels, system.state_labels
    (['velocity_command'], ['inclination'], ['inclination[t-1]', 'velocity_command[t-1]'])
    """
    state_map = _state_map(system, bounds)

    def update(t: float, x: FloatArray, u: FloatArray, params: Any) -> FloatArray:
        return state_map.update(x, u)

    def output(t: float, x: FloatArray, u: FloatArray, params: Any) -> FloatArray:
        return state_map.output(x, u)

    return control.nlsys(
        update,
        output,
        inputs=state_map.inputs,
        outputs=state_map.outputs,
        states=state_map.states,
        dt=state_map.ts,
        name=name or type(system).__name__,
    )


def initial_state(
    system: Any, y0: ArrayLike | None = None, u0: ArrayLike | None = None
) -> FloatArray:
    """The state vector of :func:`to_iosystem` (and ``to_control(form="ss")``) at given initial conditions.

    Parameters
    ----------
    system : fitted estimator, InclinationController or VelocityDrive
        As for :func:`to_iosystem`.
    y0 : array_like, shape (n_outputs,) or (m, n_outputs), optional
        Past outputs, oldest first, ``m = max(max_lag_, 1)``; one row is repeated; default zeros
        (what ``simulator().reset(y0=..., u0=...)`` takes).
    u0 : array_like, shape (n_inputs,) or (m, n_inputs), optional
        Past inputs, the same way.

    Returns
    -------
    ndarray, shape (n_states,)
        For the controller and the drive, zeros (their ``reset()``).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> from neckid.interop import initial_state
    >>> data = IOData(np.sin(np.arange(50.0)), np.cos(np.arange(50.0)), ts=0.02)
    >>> model = LinearARX(Lags.arx(2, 1)).fit(data)
    >>> initial_state(model, y0=[[1.0], [2.0]], u0=0.5)
    array([1. , 2. , 0.5, 0.5])
    """
    return _state_map(system).initial_state(y0, u0)
