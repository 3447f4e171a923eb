"""GainScheduledModel: a first-order model whose gain and pole depend on the neck's inclination.

At each operating point the seed paper (section IV) identifies, by CFF-RLS, the first-order model
``G(z) = N / (z − P)`` from motor velocity to inclination rate, then fits straight lines
``N(i)`` and ``P(i)`` through the points against the inclination ``i``. This module holds that
scheduled (LPV) model: fitting the lines, simulating it in free run with the scheduling variable
taken from its own simulated inclination, a step-by-step simulator, and the frozen transfer function
at a given inclination. :func:`neckid.experiments.operating_points.identify_operating_points` gives
the points.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator

from neckid.data import IOData, check_finite
from neckid.models.base import ModelResult, check_is_fitted
from neckid.models.io import ModelFile, register_model

if TYPE_CHECKING:
    import control

    from neckid.experiments.operating_points import OperatingPointResult

__all__ = ["GainScheduledModel", "GainScheduledSimulator"]

FloatArray = NDArray[np.float64]

#: The seed paper's lines (section IV), inclination in degrees:
#: ``N = −0.059 i + 1.857`` and ``P = 0.01175 i − 0.4797``.
PAPER_GAIN_COEFFICIENTS = (-0.059, 1.857)
PAPER_POLE_COEFFICIENTS = (0.01175, -0.4797)


def _vector(values: ArrayLike, argument: str) -> FloatArray:
    try:
        array = np.asarray(values, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{argument} must be a sequence of numbers; got {values!r}") from exc
    check_finite(array[:, None], argument)
    return array


@register_model
class GainScheduledModel(BaseEstimator, ModelFile):
    """First-order inclination-scheduled model ``G(z, i) = N(i) / (z − P(i))``, integrated.

    From the velocity command ``u`` [rad/s] to the inclination rate ``r`` [deg/s]:

    ``r(t) = P(i(t−1)) · r(t−1) + N(i(t−1)) · u(t−1)``

    and the inclination [deg] is its backward-Euler integral ``i(t) = i(t−1) + ts · r(t)``, the exact
    inverse of the rate ``r(t) = (i(t) − i(t−1)) / ts`` that the operating-point protocol identifies.
    ``N(i)`` and ``P(i)`` are polynomials in the inclination (straight lines by default, as the seed
    paper) fitted by least squares to operating points. In free run the scheduling variable is the
    model's own simulated inclination of the previous sample.

    Parameters
    ----------
    degree : int, default 1
        Degree of the polynomials ``N(i)`` and ``P(i)`` (1: straight lines).
    ts : float, optional
        Sampling period in seconds. Taken from the operating-point result when fitted on one;
        required when fitting on plain arrays.
    input : str, default "velocity_command"
        Name of the input channel read from an :class:`~neckid.IOData` by :meth:`simulate` (the
        simulated neck's :func:`~neckid.plant.closed_loop` log calls it so). A log with a single
        input channel is used whatever its name.
    output : str, default "inclination"
        Name of the inclination channel [deg] (initial condition and name of the result).
    delay : int, optional
        Input delay ``d`` >= 1 in samples: ``r(t) = P r(t−1) + N u(t−d)``, i.e.
        ``G(z, i) = N(i) z^{-(d-1)} / (z − P(i))``. Default: the delay the operating points were
        identified with (``OperatingPointResult.settings["delay"]``), or 1 (the seed paper's model)
        when fitting on plain arrays. A sensor with a few samples of latency is better described
        with ``d`` = latency + 1.

    Attributes
    ----------
    gain_coefficients_ : ndarray, shape (degree + 1,)
        Coefficients of ``N(i)``, highest power first (``numpy.polyval`` order): for a line,
        ``[slope, intercept]``. Units of ``N``: (deg/s) / (rad/s).
    pole_coefficients_ : ndarray, shape (degree + 1,)
        Coefficients of ``P(i)``, highest power first. ``P`` is dimensionless (a discrete pole).
    inclinations_, gains_, poles_ : ndarray, shape (n_points,)
        The operating points the lines were fitted to (inclination in degrees).
    gain_rmse_, pole_rmse_ : float
        Root-mean-square residual of each fit.
    ts_ : float
        Sampling period in seconds.
    delay_ : int
        Input delay used, in samples.

    Notes
    -----
    The lines minimise ``Σ (N_k − N(i_k))²`` and ``Σ (P_k − P(i_k))²`` over the points
    (``numpy.polyfit``). The seed paper reports, for its neck at 50 Hz,
    ``N = −0.059 i + 1.857`` and ``P = 0.01175 i − 0.4797`` (``PAPER_GAIN_COEFFICIENTS``,
    ``PAPER_POLE_COEFFICIENTS``). Whether the paper's rate is per second or per sample is not
    stated; here it is per second, so ``N`` scales with ``1 / ts`` if the other is meant.

    References
    ----------
    .. [1] UC3M Robotics Lab, "Model Identification of a Soft Robotic Neck", section IV and Fig. 6.
    .. [2] I. D. Landau, R. Lozano, M. M'Saad, A. Karimi, *Adaptive Control*, Springer, 2011.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid.models.scheduled import GainScheduledModel
    >>> i = np.array([5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0])
    >>> model = GainScheduledModel(ts=0.02).fit(i, -0.059 * i + 1.857, 0.01175 * i - 0.4797)
    >>> np.round(model.gain_coefficients_, 4), np.round(model.pole_coefficients_, 5)
    (array([-0.059,  1.857]), array([ 0.01175, -0.4797 ]))
    >>> model.transfer_function(20.0).dt
    0.02
    >>> result = model.simulate(np.full(100, 0.5), y0=20.0)
    >>> result.kind, result.y.shape
    ('simulation', (100, 1))
    """

    def __init__(
        self,
        degree: int = 1,
        ts: float | None = None,
        input: str = "velocity_command",
        output: str = "inclination",
        delay: int | None = None,
    ) -> None:
        self.degree = degree
        self.ts = ts
        self.input = input
        self.output = output
        self.delay = delay

    # ------------------------------------------------------------------ fit
    def fit(
        self,
        inclinations: ArrayLike | OperatingPointResult,
        gains: ArrayLike | None = None,
        poles: ArrayLike | None = None,
        *,
        converged_only: bool = True,
    ) -> GainScheduledModel:
        """Fit ``N(i)`` and ``P(i)`` by least squares to operating points.

        Parameters
        ----------
        inclinations : array_like of shape (n_points,), or OperatingPointResult
            Inclination of each point [deg], or the result of the operating-point protocol (then
            ``gains`` and ``poles`` are taken from it, and ``ts`` too when not set).
        gains, poles : array_like of shape (n_points,)
            ``N`` and ``P`` at each point; required with plain arrays.
        converged_only : bool, default True
            With an :class:`OperatingPointResult`, use only the points whose estimate converged.

        Returns
        -------
        GainScheduledModel
            ``self``.

        Raises
        ------
        ValueError
            If there are fewer distinct inclinations than ``degree + 1``, the lengths differ, a value
            is not finite, ``degree < 0`` or ``ts`` is missing or not positive.
        """
        from neckid.experiments.operating_points import OperatingPointResult

        ts = self.ts
        delay = self.delay
        if isinstance(inclinations, OperatingPointResult):
            if delay is None:
                delay = int(inclinations.settings.get("delay", 1))
            if gains is not None or poles is not None:
                raise ValueError(
                    "give either an OperatingPointResult or the arrays inclinations, gains and"
                    " poles, not both"
                )
            table = inclinations.table
            if converged_only:
                table = table[table["converged"]]
            i_values = table["inclination"].to_numpy(dtype=np.float64)
            n_values = table["gain"].to_numpy(dtype=np.float64)
            p_values = table["pole"].to_numpy(dtype=np.float64)
            if ts is None:
                ts = inclinations.ts
        else:
            if gains is None or poles is None:
                raise ValueError("gains and poles are required with an array of inclinations")
            i_values = _vector(inclinations, "inclinations")
            n_values = _vector(gains, "gains")
            p_values = _vector(poles, "poles")
        if not (i_values.size == n_values.size == p_values.size):
            raise ValueError(
                f"inclinations, gains and poles must have the same length; got {i_values.size},"
                f" {n_values.size} and {p_values.size}"
            )
        degree = self.degree
        if isinstance(degree, bool) or not isinstance(degree, int | np.integer) or degree < 0:
            raise ValueError(f"degree must be a whole number >= 0; got {degree!r}")
        distinct = np.unique(i_values).size
        if distinct < degree + 1:
            raise ValueError(
                f"a polynomial of degree {degree} needs at least {degree + 1} distinct inclinations;"
                f" got {distinct} (of {i_values.size} points"
                f"{', converged only' if converged_only and ts is not None else ''})"
            )
        if ts is None:
            raise ValueError("ts is required: GainScheduledModel(ts=...) in seconds")
        ts_value = float(ts)
        if not math.isfinite(ts_value) or ts_value <= 0:
            raise ValueError(f"ts must be a positive number of seconds; got {ts!r}")

        self.gain_coefficients_ = np.polyfit(i_values, n_values, int(degree))
        self.pole_coefficients_ = np.polyfit(i_values, p_values, int(degree))
        self.inclinations_ = i_values
        self.gains_ = n_values
        self.poles_ = p_values
        self.gain_rmse_ = float(
            np.sqrt(np.mean((np.polyval(self.gain_coefficients_, i_values) - n_values) ** 2))
        )
        self.pole_rmse_ = float(
            np.sqrt(np.mean((np.polyval(self.pole_coefficients_, i_values) - p_values) ** 2))
        )
        if delay is None:
            delay = 1
        if isinstance(delay, bool) or not isinstance(delay, int | np.integer) or delay < 1:
            raise ValueError(f"delay must be a whole number of samples >= 1; got {delay!r}")
        self.ts_ = ts_value
        self.delay_ = int(delay)
        return self

    @classmethod
    def from_coefficients(
        cls,
        gain_coefficients: ArrayLike = PAPER_GAIN_COEFFICIENTS,
        pole_coefficients: ArrayLike = PAPER_POLE_COEFFICIENTS,
        ts: float = 0.02,
        **params: Any,
    ) -> GainScheduledModel:
        """A fitted model from given polynomial coefficients (highest power first).

        The defaults are the seed paper's lines at ``ts = 0.02`` s.

        Examples
        --------
        >>> paper = GainScheduledModel.from_coefficients()
        >>> round(float(paper.gain(20.0)), 3), round(float(paper.pole(20.0)), 4)
        (0.677, -0.2447)
        """
        gain = _vector(gain_coefficients, "gain_coefficients")
        pole = _vector(pole_coefficients, "pole_coefficients")
        if gain.size != pole.size or gain.size == 0:
            raise ValueError(
                "gain_coefficients and pole_coefficients must be non-empty and of the same length;"
                f" got {gain.size} and {pole.size}"
            )
        model = cls(degree=gain.size - 1, ts=ts, **params)
        model.gain_coefficients_ = gain
        model.pole_coefficients_ = pole
        model.inclinations_ = np.zeros(0)
        model.gains_ = np.zeros(0)
        model.poles_ = np.zeros(0)
        model.gain_rmse_ = math.nan
        model.pole_rmse_ = math.nan
        model.ts_ = float(ts)
        delay = 1 if model.delay is None else model.delay
        if isinstance(delay, bool) or not isinstance(delay, int | np.integer) or delay < 1:
            raise ValueError(f"delay must be a whole number of samples >= 1; got {delay!r}")
        model.delay_ = int(delay)
        return model

    # ------------------------------------------------------------------ the model
    def gain(self, inclination: ArrayLike) -> FloatArray:
        """``N(i)`` at inclination(s) ``i`` [deg]."""
        check_is_fitted(self, "gain_coefficients_")
        return np.asarray(
            np.polyval(self.gain_coefficients_, np.asarray(inclination, dtype=np.float64))
        )

    def pole(self, inclination: ArrayLike) -> FloatArray:
        """``P(i)`` at inclination(s) ``i`` [deg]."""
        check_is_fitted(self, "pole_coefficients_")
        return np.asarray(
            np.polyval(self.pole_coefficients_, np.asarray(inclination, dtype=np.float64))
        )

    def transfer_function(
        self, inclination: float, to: Literal["rate", "inclination"] = "rate"
    ) -> control.TransferFunction:
        """The frozen model at inclination ``i`` as a python-control ``TransferFunction`` (``dt = ts``).

        Parameters
        ----------
        inclination : float
            Operating point [deg].
        to : {"rate", "inclination"}, default "rate"
            ``"rate"``: ``N z^{-(d-1)} / (z − P)`` from velocity command [rad/s] to inclination
            rate [deg/s]; ``"inclination"``: ``N · ts · z^{2-d} / ((z − P)(z − 1))`` to inclination
            [deg] (the rate integrated as ``i(t) = i(t−1) + ts · r(t)``); ``d`` is ``delay_``.

        Returns
        -------
        control.TransferFunction
            Discrete-time, with ``dt`` the sampling period in seconds.
        """
        import control

        check_is_fitted(self, "gain_coefficients_")
        value = float(inclination)
        if not math.isfinite(value):
            raise ValueError(f"inclination must be a finite number of degrees; got {inclination!r}")
        n = float(self.gain(value))
        p = float(self.pole(value))
        extra = [0.0] * (self.delay_ - 1)  # z^{-(d-1)}: d - 1 more poles at the origin
        if to == "rate":
            return control.TransferFunction([n], [1.0, -p, *extra], dt=self.ts_)
        if to == "inclination":
            return control.TransferFunction(
                [n * self.ts_, 0.0], [1.0, -(1.0 + p), p, *extra], dt=self.ts_
            )
        raise ValueError(f"to must be 'rate' or 'inclination'; got {to!r}")

    # ------------------------------------------------------------------ simulation
    def simulator(self) -> GainScheduledSimulator:
        """A stateful simulator with ``reset(y0, rate0, u0)`` and ``step(u) -> inclination``."""
        check_is_fitted(self, "gain_coefficients_")
        return GainScheduledSimulator(self)

    def simulate(
        self,
        data: IOData | ArrayLike,
        y0: float | None = None,
        *,
        rate0: float = 0.0,
    ) -> ModelResult:
        """Free run from a velocity-command sequence; the schedule follows the simulated inclination.

        Parameters
        ----------
        data : IOData or array_like of shape (n_samples,) or (n_samples, 1)
            Velocity command [rad/s]. From an IOData the channel named ``input`` is used (or its only
            input), and the first sample of the channel named ``output`` is the initial inclination.
        y0 : float, optional
            Initial inclination [deg]; overrides the one from ``data``. Required with an array.
        rate0 : float, default 0.0
            Initial inclination rate [deg/s] (0: the neck at rest).

        Returns
        -------
        ModelResult
            ``kind="simulation"``, inclination [deg] in ``y``, ``n_initial = 1`` (sample 0 is the
            initial condition); ``extras`` holds ``"rate"``, ``"gain"`` and ``"pole"`` per sample.

        Raises
        ------
        ValueError
            If ``y0`` is missing with an array, or the input has several channels.
        KeyError
            If the IOData has several inputs and none named ``input``.
        """
        check_is_fitted(self, "gain_coefficients_")
        if isinstance(data, IOData):
            u = self._input_of(data)
            time = data.time
            if y0 is None:
                y0 = float(data.channel(self._output_name(data))[0])
        else:
            u = np.asarray(data, dtype=np.float64)
            if u.ndim == 2 and u.shape[1] == 1:
                u = u[:, 0]
            if u.ndim != 1:
                raise ValueError(
                    f"u must be one velocity-command channel, shape (n_samples,); got {np.shape(data)}"
                )
            check_finite(u[:, None], "u")
            time = self.ts_ * np.arange(u.size, dtype=np.float64)
            if y0 is None:
                raise ValueError(
                    "y0 (the initial inclination in degrees) is required with an array u"
                )
        sim = GainScheduledSimulator(self)
        sim.reset(y0=y0, rate0=rate0, u0=u[0] if u.size else 0.0)
        y = np.empty(u.size)
        rate = np.empty(u.size)
        gain = np.empty(u.size)
        pole = np.empty(u.size)
        y[0], rate[0] = sim.inclination, sim.rate
        gain[0], pole[0] = math.nan, math.nan
        for t in range(1, u.size):
            gain[t] = sim.current_gain
            pole[t] = sim.current_pole
            y[t] = sim.step(u[t])[0]
            rate[t] = sim.rate
        return ModelResult(
            "simulation",
            time,
            y[:, None],
            (self.output,),
            1,
            extras={"rate": rate, "gain": gain, "pole": pole},
        )

    def _input_of(self, data: IOData) -> FloatArray:
        if self.input in data.input_names:
            return np.asarray(data.channel(self.input))
        if data.n_inputs == 1:
            return np.asarray(data.u[:, 0])
        raise KeyError(
            f"data has no input named {self.input!r} and several inputs {list(data.input_names)};"
            " set GainScheduledModel(input=...) to the velocity-command channel"
        )

    def _output_name(self, data: IOData) -> str:
        if self.output in data.output_names or self.output in data.input_names:
            return self.output
        if data.n_outputs == 1:
            return data.output_names[0]
        raise KeyError(
            f"data has no channel named {self.output!r}; set GainScheduledModel(output=...) to the"
            f" inclination channel (outputs are {list(data.output_names)})"
        )

    # ------------------------------------------------------------------ files
    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self, "gain_coefficients_")
        arrays = {
            "gain_coefficients": self.gain_coefficients_,
            "pole_coefficients": self.pole_coefficients_,
            "inclinations": self.inclinations_,
            "gains": self.gains_,
            "poles": self.poles_,
        }
        meta = {
            "params": {
                "degree": int(self.degree),
                "ts": None if self.ts is None else float(self.ts),
                "input": str(self.input),
                "output": str(self.output),
                "delay": None if self.delay is None else int(self.delay),
            },
            "ts": self.ts_,
            "delay": self.delay_,
            "gain_rmse": self.gain_rmse_,
            "pole_rmse": self.pole_rmse_,
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
    ) -> GainScheduledModel:
        model = cls(**meta["params"])
        model.gain_coefficients_ = np.asarray(arrays["gain_coefficients"], dtype=np.float64)
        model.pole_coefficients_ = np.asarray(arrays["pole_coefficients"], dtype=np.float64)
        model.inclinations_ = np.asarray(arrays["inclinations"], dtype=np.float64)
        model.gains_ = np.asarray(arrays["gains"], dtype=np.float64)
        model.poles_ = np.asarray(arrays["poles"], dtype=np.float64)
        model.gain_rmse_ = float(meta["gain_rmse"])
        model.pole_rmse_ = float(meta["pole_rmse"])
        model.ts_ = float(meta["ts"])
        model.delay_ = int(meta.get("delay", 1))
        return model


class GainScheduledSimulator:
    """Step-by-step free run of a :class:`GainScheduledModel`, for a closed loop beside a controller.

    ``step(u)`` takes the velocity command at the current time ``t`` [rad/s] and returns the
    inclination ``i(t)`` [deg], which depends on the commands up to ``t − d`` (``d = delay_``):
    ``r(t) = P(i(t−1)) r(t−1) + N(i(t−1)) u(t−d)``, ``i(t) = i(t−1) + ts r(t)``.
    """

    def __init__(self, model: GainScheduledModel) -> None:
        self._gain = np.asarray(model.gain_coefficients_, dtype=np.float64)
        self._pole = np.asarray(model.pole_coefficients_, dtype=np.float64)
        self.ts = float(model.ts_)
        self.delay = int(model.delay_)
        self.n_inputs = 1
        self.n_outputs = 1
        self.reset()

    def reset(self, y0: float = 0.0, rate0: float = 0.0, u0: float = 0.0) -> None:
        """Start again at inclination ``y0`` [deg], rate ``rate0`` [deg/s], past commands ``u0``."""
        values = np.array([y0, rate0, u0], dtype=np.float64).reshape(-1)
        if values.size != 3:
            raise ValueError(f"y0, rate0 and u0 must be scalars; got {y0!r}, {rate0!r}, {u0!r}")
        check_finite(values[None, :], "initial state", ["y0", "rate0", "u0"])
        self.inclination = float(values[0])
        self.rate = float(values[1])
        self._past_u = [float(values[2])] * self.delay  # u(t-d), ..., u(t-1)

    @property
    def current_gain(self) -> float:
        """``N`` at the current inclination (used by the next step)."""
        return float(np.polyval(self._gain, self.inclination))

    @property
    def current_pole(self) -> float:
        """``P`` at the current inclination (used by the next step)."""
        return float(np.polyval(self._pole, self.inclination))

    def step(self, u: float | ArrayLike) -> FloatArray:
        """Advance one sample with command ``u`` [rad/s]; return the inclination, shape ``(1,)``."""
        u_now = np.asarray(u, dtype=np.float64).reshape(-1)
        if u_now.size != 1:
            raise ValueError(f"u must be one velocity command; got {u!r}")
        check_finite(u_now[None, :], "u")
        gain = self.current_gain
        pole = self.current_pole
        self.rate = pole * self.rate + gain * self._past_u[0]
        self.inclination = self.inclination + self.ts * self.rate
        self._past_u = [*self._past_u[1:], float(u_now[0])]
        return np.array([self.inclination])
