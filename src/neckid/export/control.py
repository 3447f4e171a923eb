r"""python-control interop: identified models as transfer functions and as I/O systems.

* :func:`to_control` turns a *linear* model (:class:`~neckid.LinearARX`,
  :class:`~neckid.RecursiveARX`, :class:`~neckid.models.linear.subspace.SubspaceStateSpace`, or
  a :class:`~neckid.GainScheduledModel` frozen at one inclination) into a discrete
  ``control.StateSpace`` or ``control.TransferFunction`` with ``dt = ts_`` and the model's
  channel names, for Bode plots, margins and controller design. The form it gives by default is
  a fact of the model's method (:attr:`neckid.registry.Method.control_form`): a state space for
  the state-space models (``ss``, the scheduled models), a transfer function for the ARX models.
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

Each system gives its own state functions through one method, ``state_map(bounds=False)``
(the protocol :class:`~neckid.systems.HasStateMap`, as python-control's ``NonlinearIOSystem``
takes an update and an output function of the state): :func:`to_iosystem` and
:func:`initial_state` talk to that method only, so a new kind of system needs no change here.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Literal

import control
import numpy as np
from numpy.typing import ArrayLike

from neckid.models.base import Estimator, check_is_fitted
from neckid.models.koopman.model import KoopmanEDMD
from neckid.models.linear.arx import LinearARX
from neckid.models.linear.rls import RecursiveARX
from neckid.models.linear.subspace import SubspaceStateSpace
from neckid.models.lpv.model import LPVARX
from neckid.models.pnlss.linearise import linearise
from neckid.models.pnlss.model import PolynomialStateSpace
from neckid.models.scheduled.model import GainScheduledModel
from neckid.models.scheduled.state_map import command_channel, scheduled_state_names
from neckid.systems import StateFunctions, history_names
from neckid.utils.types import FloatArray

__all__ = ["default_form", "initial_state", "output_offset", "to_control", "to_iosystem"]


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
    intercept = np.asarray(model.intercept_, dtype=np.float64)
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
    >>> from neckid.export.control import output_offset
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
    states = history_names(model.output_names_, m) + history_names(model.input_names_, m)
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


def _scheduled_frozen(
    model: GainScheduledModel, inclination: float, form: str, name: str | None
) -> control.TransferFunction | control.StateSpace:
    command = model.input_names_[command_channel(model)]
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
    if model.form == "position":
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
        states=scheduled_state_names(model),
        name=label,
    )


def _subspace_system(
    model: SubspaceStateSpace,
    inclination: float | None,
    form: str,
    strict: bool,
    name: str | None,
) -> control.TransferFunction | control.StateSpace:
    """A SubspaceStateSpace as it is: ``(A, B, C, D)`` on its own state, or its transfer matrix."""
    if inclination is not None:
        raise ValueError(
            f"inclination applies to a GainScheduledModel only; got {inclination!r} for a"
            " SubspaceStateSpace"
        )
    if strict and np.any(model.intercept_):
        raise ValueError(
            f"the SubspaceStateSpace has an output offset {model.intercept_.tolist()}, which a"
            " linear system cannot hold; pass strict=False to leave it out, or fit with"
            " fit_intercept=False"
        )
    labels = {
        "inputs": list(model.input_names_),
        "outputs": list(model.output_names_),
        "name": name or type(model).__name__,
    }
    if form == "ss":
        a, b, c, d, _ = model.matrices_
        states = [f"x{k + 1}" for k in range(model.order_)]
        return control.StateSpace(a, b, c, d, dt=model.ts_, states=states, **labels)
    numerators, denominator = model.transfer_matrix()
    denominators = [[denominator] * len(row) for row in numerators]
    return control.TransferFunction(numerators, denominators, dt=model.ts_, **labels)


def _pnlss_system(
    model: PolynomialStateSpace,
    inclination: float | None,
    form: str,
    strict: bool,
    name: str | None,
) -> control.TransferFunction | control.StateSpace:
    """A PolynomialStateSpace linearised at rest, inputs mid-range (:func:`~neckid.models.pnlss.linearise.linearise`)."""
    if inclination is not None:
        raise ValueError(
            f"inclination applies to a GainScheduledModel only; got {inclination!r} for a"
            " PolynomialStateSpace (it is linearised at its equilibrium with mid-range inputs)"
        )
    linear = linearise(model)
    if strict and np.any(linear.outputs):
        raise ValueError(
            f"the PolynomialStateSpace rests at the output {linear.outputs.tolist()} (inputs"
            f" {linear.inputs.tolist()}), which a linear system cannot hold; pass strict=False to"
            " leave the equilibrium out (the system is in deviations from it)"
        )
    system = control.StateSpace(
        linear.a,
        linear.b,
        linear.c,
        linear.d,
        dt=model.ts_,
        inputs=list(model.input_names_),
        outputs=list(model.output_names_),
        states=[f"x{k + 1}" for k in range(int(model.order_))],
        name=name or type(model).__name__,
    )
    return system if form == "ss" else control.ss2tf(system, name=system.name)


def _koopman_system(
    model: KoopmanEDMD, inclination: float | None, form: str, name: str | None
) -> control.TransferFunction | control.StateSpace:
    """A KoopmanEDMD's lifted linear system as it is (its offsets are the constant state's)."""
    if inclination is not None:
        raise ValueError(
            f"inclination applies to a GainScheduledModel only; got {inclination!r} for a"
            " KoopmanEDMD (its lifted system is linear everywhere)"
        )
    lifted = model.lifted_system()
    system = control.StateSpace(
        lifted.A,
        lifted.B,
        lifted.C,
        lifted.D,
        dt=model.ts_,
        inputs=list(model.input_names_),
        outputs=list(model.output_names_),
        states=model.state_names(),
        name=name or type(model).__name__,
    )
    return system if form == "ss" else control.ss2tf(system, name=system.name)


def default_form(model: Any) -> str:
    """The python-control form :func:`to_control` gives ``model`` by default (``"tf"`` or ``"ss"``).

    Its method's :attr:`~neckid.registry.Method.control_form`, found through the model's class
    and its bases (a subclass of a registered class takes that class's form); ``"tf"`` for a
    class no method is registered with.

    Examples
    --------
    >>> from neckid import Lags, LinearARX
    >>> from neckid.models.linear.subspace import SubspaceStateSpace
    >>> default_form(LinearARX(Lags.arx(1, 1))), default_form(SubspaceStateSpace())
    ('tf', 'ss')
    """
    from neckid.registry import methods

    by_class = {m.class_name: m.control_form for m in methods().values()}
    names = (cls.__name__ for cls in type(model).__mro__)
    return next((by_class[n] for n in names if n in by_class), "tf")


def to_control(
    model: Any,
    *,
    inclination: float | None = None,
    form: Literal["tf", "ss"] | None = None,
    strict: bool = False,
    name: str | None = None,
    scheduling: Mapping[str, Any] | None = None,
) -> Any:
    r"""A linear model as a discrete python-control system (``dt = ts_``, channels named).

    Parameters
    ----------
    model : LinearARX, RecursiveARX, GainScheduledModel, SubspaceStateSpace, PolynomialStateSpace, LPVARX or KoopmanEDMD
        Fitted. ARX models: from every input to every output (MIMO when there are several).
        ``SubspaceStateSpace``: its ``(A_, B_, C_, D_)`` on its own state ``x1 … xn`` (``"ss"``,
        started by ``X0 = model.initial_state(y[:m], u[:m])``), or its transfer matrix; the
        offset ``intercept_`` is left out (added to the output) as an ARX intercept is.
        ``PolynomialStateSpace``: linearised at rest with its inputs at the middle of their
        training range (:func:`neckid.models.pnlss.linearise.linearise`: exact derivatives of
        its monomials at the equilibrium), in deviations from that equilibrium.
        ``KoopmanEDMD``: its lifted linear system ``z⁺ = A z + B u``, ``y = C z + D u``
        (:meth:`~neckid.models.koopman.model.KoopmanEDMD.lifted_system`, exact: the offsets sit
        in its constant state), started by ``X0 = model.initial_state(y[:m], u[:m])``.
        ``RecursiveARX``: its final estimate ``coef_``. ``GainScheduledModel``: frozen at
        ``inclination``, from the velocity command [rad/s] to the inclination [deg]
        (:meth:`~neckid.GainScheduledModel.transfer_function` with ``to="inclination"``).
    inclination : float, optional
        Operating point [deg]; required for a ``GainScheduledModel``, refused otherwise.
    form : {"tf", "ss"}, optional
        ``"tf"``: a ``control.TransferFunction``. ``"ss"``: a ``control.StateSpace``; for an ARX
        model its state is the one of :func:`to_iosystem` (so ``X0 = initial_state(model, y0,
        u0)`` starts it from given initial conditions, and a MIMO model simulates without
        slycot). Default: the model's method's form (:func:`default_form`): ``"ss"`` for
        ``SubspaceStateSpace`` and ``GainScheduledModel`` (python-control turns a MIMO transfer
        function back into a state space only with slycot), ``"tf"`` for the ARX models.
    strict : bool, default False
        Refuse a model with a non-zero intercept instead of leaving the intercept out.
    name : str, optional
        The system's name (default the class name).
    scheduling : mapping of str, optional
        For an :class:`~neckid.models.lpv.model.LPVARX` (required there, refused otherwise): the
        value of every scheduling variable (``{"payload": 0.4}``); the system is the ARX frozen
        there (:meth:`~neckid.models.lpv.model.LPVARX.frozen`), a scheduling condition no
        input of it.

    Returns
    -------
    control.StateSpace or control.TransferFunction

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
    >>> from neckid.export.control import to_control
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
    if form is None:
        form = "ss" if default_form(model) == "ss" else "tf"
    if form not in ("tf", "ss"):
        raise ValueError(f"form must be 'tf' or 'ss'; got {form!r}")
    if isinstance(model, GainScheduledModel):
        if inclination is None:
            raise ValueError(
                "inclination is required for a GainScheduledModel: the operating point [deg] to"
                " freeze N(i) / (z - P(i)) at, e.g. to_control(model, inclination=20.0)"
            )
        return _scheduled_frozen(model, float(inclination), form, name)
    if isinstance(model, LPVARX) and inclination is None:
        if scheduling is None:
            raise ValueError(
                "scheduling is required for an LPVARX: the values to freeze its coefficients at,"
                f" e.g. to_control(model, scheduling={{{model.scheduling_[0].name!r}: ...}})"
            )
        label = ",".join(f"{k}={v}" for k, v in scheduling.items()).replace(".", "p")
        frozen = model.frozen(**dict(scheduling))
        return to_control(frozen, form=form, strict=strict, name=name or f"LPVARX@{label}")
    if scheduling is not None:
        raise ValueError(
            f"scheduling applies to an LPVARX only; got {dict(scheduling)!r} for a"
            f" {type(model).__name__}"
        )
    if isinstance(model, SubspaceStateSpace):
        return _subspace_system(model, inclination, form, strict, name)
    if isinstance(model, PolynomialStateSpace):
        return _pnlss_system(model, inclination, form, strict, name)
    if isinstance(model, KoopmanEDMD):
        return _koopman_system(model, inclination, form, name)
    if not isinstance(model, LINEAR_MODELS):
        raise TypeError(
            f"to_control needs a linear model (LinearARX, RecursiveARX, GainScheduledModel); a"
            f" {type(model).__name__} is nonlinear: use neckid.export.control.to_iosystem(model) for a"
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
def _state_map(system: Any, bounds: bool = False) -> StateFunctions:
    """The system's own state functions (:class:`~neckid.systems.HasStateMap`), fitted."""
    make = None if isinstance(system, type) else getattr(system, "state_map", None)
    if not callable(make):
        raise TypeError(
            "to_iosystem takes a fitted neckid model, an InclinationController or a"
            f" VelocityDrive; got {type(system).__name__}"
        )
    if callable(getattr(system, "__sklearn_is_fitted__", None)):
        check_is_fitted(system)
    state_map: StateFunctions = make(bounds)
    return state_map


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
        ``motor_position`` and ``motor_velocity``). Any object with a ``state_map`` method
        (:class:`~neckid.systems.HasStateMap`) fits.
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
    >>> from neckid.export.control import initial_state, to_iosystem
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
    >>> from neckid.export.control import initial_state
    >>> data = IOData(np.sin(np.arange(50.0)), np.cos(np.arange(50.0)), ts=0.02)
    >>> model = LinearARX(Lags.arx(2, 1)).fit(data)
    >>> initial_state(model, y0=[[1.0], [2.0]], u0=0.5)
    array([1. , 2. , 0.5, 0.5])
    """
    return _state_map(system).initial_state(y0, u0)
