"""GainScheduledModel: a first-order model whose gain and pole depend on the neck's inclination.

At each operating point the seed paper (section IV) identifies, by CFF-RLS, the first-order model
``G(z) = N / (z − P)`` from motor velocity to inclination rate, then fits straight lines
``N(i)`` and ``P(i)`` through the points against the inclination ``i``. This module holds that
scheduled (LPV) model, in the paper's rate form or in a position form (motor position to
inclination, no integrator): fitting the lines through the points that
:func:`~neckid.models.scheduled.points.identify_point` finds on records, simulating it in free
run with the scheduling variable taken from its own simulated inclination (clipped to the
identified range, the pole kept inside the unit circle), a step-by-step simulator, and the frozen
transfer function at a given inclination.
:func:`neckid.loops.operating_points.identify_operating_points` runs the protocol on a plant.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import Estimator, ModelResult, check_is_fitted
from neckid.models.scheduled.point_table import (
    given_table,
    point_table,
    table_arrays,
    table_from_arrays,
)
from neckid.models.scheduled.points import (
    FORMS,
    OperatingPoint,
    default_window,
    identify_point,
    identify_segments,
)
from neckid.models.scheduled.regressor import default_lags, first_order_terms
from neckid.models.scheduled.segments import (
    SEGMENTATIONS,
    OperatingSegment,
    operating_segments,
)
from neckid.models.scheduled.simulator import GainScheduledSimulator, clipped_polyval
from neckid.models.scheduled.state_map import ScheduledStateMap
from neckid.models.scheduled.summary import describe_schedule
from neckid.regressors import Lags, ResolvedLags
from neckid.utils.checks import Interval, Options, check_number, check_ts, check_vector
from neckid.utils.types import FloatArray

if TYPE_CHECKING:
    import control

__all__ = [
    "DEFAULT_SEGMENTS",
    "GainScheduledModel",
    "GainScheduledSimulator",
    "OperatingPoint",
    "default_window",
    "identify_point",
]


#: The seed paper's lines (section IV), inclination in degrees:
#: ``N = −0.059 i + 1.857`` and ``P = 0.01175 i − 0.4797``.
PAPER_GAIN_COEFFICIENTS = (-0.059, 1.857)
PAPER_POLE_COEFFICIENTS = (0.01175, -0.4797)


#: How records are cut into operating points when ``segments`` is not given: their dwells
#: (:mod:`neckid.models.scheduled.segments`), or inclination bins when they hold too few.
DEFAULT_SEGMENTS = "dwell"

#: Default bound on the pole: ``|P(i)| <= 0.99`` wherever the line is evaluated.
DEFAULT_POLE_BOUND = 0.99

Form = Literal["rate", "position"]


def _schedule_limits(values: ArrayLike) -> FloatArray:
    """``schedule_range`` as ``[low, high]`` [deg], ``low <= high`` (infinite ends allowed)."""
    limits = np.asarray(values, dtype=np.float64)
    if limits.shape != (2,) or not limits[0] <= limits[1]:
        raise ValueError(
            f"schedule_range must be [low, high] in degrees with low <= high (infinite ends"
            f" allowed); got {limits.tolist()}"
        )
    return limits


class GainScheduledModel(Estimator):
    """First-order inclination-scheduled model ``G(z, i) = N(i) / (z − P(i))``.

    Two forms. ``form="rate"`` is the seed paper's: from the velocity command ``u`` [rad/s] to
    the inclination rate ``r`` [deg/s],

    ``r(t) = P(s) · r(t−1) + N(s) · u(t−d)``,

    and the inclination [deg] is its backward-Euler integral ``i(t) = i(t−1) + ts · r(t)``, the exact
    inverse of the rate ``r(t) = (i(t) − i(t−1)) / ts`` that the operating-point protocol identifies.
    ``form="position"`` has no integrator: from a motor position ``u`` [rad] (the displacement
    since the log's start, say) to the inclination itself,

    ``i(t) = P(s) · i(t−1) + N(s) · u(t−d)``.

    ``N(i)`` and ``P(i)`` are polynomials in the inclination (straight lines by default, as the seed
    paper) fitted by least squares to operating points. The scheduling variable ``s`` is the
    inclination of the previous sample (in free run the model's own) clipped to the range of the
    operating points, ``schedule_range_``: outside it the lines are held at their end values
    instead of extrapolated. The pole is clipped to ``[−pole_bound, pole_bound]``.

    ``fit(data)`` finds the operating points itself: by default where the inclination dwells
    (:mod:`neckid.models.scheduled.segments`: a 2° band held for four memories of the
    estimator), else in inclination bins; CFF-RLS (:func:`identify_point`) gives each point's
    ``N`` and ``P``. Points identified elsewhere (:func:`neckid.identify_operating_points` on a
    plant) give a model through :meth:`from_points`.

    Parameters
    ----------
    lags : Lags, optional
        ``Lags.arx(1, 1, d)``: the input delay ``d`` >= 1 of ``G(z, i) = N(i) z^{-(d-1)} / (z − P(i))``
        (the seed paper's ``d = 1``; a sensor with a few samples of latency is better described
        with ``d`` = latency + 1). With several inputs, ``Lags(outputs=[1], inputs={name: [d]})``
        picks the command (velocity command, or motor position in the position form). Default
        (``None``): ``d = 1`` on the one input of the data (data with several inputs are
        refused, with the names to choose from). On the command line: ``--lags 1/D``.
    form : {"rate", "position"}, default "rate"
        ``"rate"``: the seed paper's velocity-to-rate model; ``"position"``: position to
        inclination. The form goes with the command chosen in ``lags``, so the default stays
        the paper's. On the real soft-neck stair logs the position form on the motor
        displacement is the one to use: its mean free-run fit, a training log held out at a
        time, is 64–70 %, the rate form's at most 21 % (it drifts; see Notes).
    degree : int, default 1
        Degree of the polynomials ``N(i)`` and ``P(i)`` (1: straight lines).
    forgetting_factor : float, default 0.98
        CFF-RLS ``λ`` at each operating point (the seed paper's value).
    segments : {"dwell", "bins"}, int or array_like of float, default "dwell"
        Where the operating points lie (:func:`~neckid.models.scheduled.segments.operating_segments`):
        ``"dwell"``: one point per dwell of every record (where the smoothed inclination stays
        within 2° for at least ``4 / (1 − λ)`` samples), or inclination bins when fewer than
        ``degree + 1`` dwells are found; ``"bins"``: bins only; an int ``n``: ``n`` equal
        parts of every record (``1``: one point per record); an array: boundaries in seconds
        from each record's start (the stairs of a staircase log). ``None`` reads as
        ``"dwell"``. ``segmentation_`` says which rule gave the points.
    skip : int, default 0
        Samples left out at the start of every dwell or segment (its transient); for a bin, of
        every stretch that makes it up.
    window : int, optional
        Convergence window of the RLS estimate and samples averaged per point, default
        ``5 / (1 − λ)`` (250 samples at λ = 0.98), at most half of each segment after ``skip``.
    converged_only : bool, default True
        Fit the lines through the converged points only. When fewer than ``degree + 1``
        distinct inclinations converged, the lines go through every point and a warning says
        how many converged (``operating_points_`` keeps the flags).
    pole_bound : float, default 0.99
        ``|P(s)|`` is held at most this, in (0, 1): the frozen model stays stable wherever it is.

    Attributes
    ----------
    gain_coefficients_ : ndarray, shape (degree + 1,)
        Coefficients of ``N(i)``, highest power first (``numpy.polyval`` order): for a line,
        ``[slope, intercept]``. Units of ``N``: (deg/s) / (rad/s) in the rate form, deg/rad in
        the position form.
    pole_coefficients_ : ndarray, shape (degree + 1,)
        Coefficients of ``P(i)``, highest power first. ``P`` is dimensionless (a discrete pole).
    inclinations_, gains_, poles_ : ndarray, shape (n_points,)
        The operating points the lines were fitted to (inclination in degrees).
    operating_points_ : pandas.DataFrame
        Every point found, used or not: columns ``inclination`` [deg], ``gain``, ``pole``,
        ``converged``, ``used``, ``start_s``, ``stop_s``, ``n_samples``, ``experiment``,
        ``kind`` (:data:`~neckid.models.scheduled.point_table.POINT_COLUMNS`).
    segmentation_ : str
        The rule that gave the points: ``"dwell"``, ``"bins"``, ``"equal"``, ``"edges"``, or
        ``"given"`` (:meth:`from_points`, :meth:`from_coefficients`).
    n_samples_ : int
        Samples of the training records (0 for a model from given points or coefficients).
    command_unit_ : str
        Unit of the command (``""`` when unknown).
    schedule_range_ : ndarray, shape (2,)
        ``[low, high]`` [deg] the scheduling variable is clipped to: the range of
        ``inclinations_`` (``[-inf, inf]`` for a model from :meth:`from_coefficients`).
    gain_rmse_, pole_rmse_ : float
        Root-mean-square residual of each fit.
    delay_ : int
        Input delay used, in samples.
    max_lag_ : int
        1: a simulation starts from the first inclination (in the rate form, at rest: rate 0).
    lags_ : ResolvedLags
    ts_ : float
    n_inputs_, n_outputs_ : int

    Notes
    -----
    The lines minimise ``Σ (N_k − N(i_k))²`` and ``Σ (P_k − P(i_k))²`` over the points
    (``numpy.polyfit``). The seed paper reports, for its neck at 50 Hz,
    ``N = −0.059 i + 1.857`` and ``P = 0.01175 i − 0.4797`` (``PAPER_GAIN_COEFFICIENTS``,
    ``PAPER_POLE_COEFFICIENTS``). Whether the paper's rate is per second or per sample is not
    stated; here it is per second, so ``N`` scales with ``1 / ts`` if the other is meant.

    Why the clipping and the position form: in free run the rate form integrates, so a biased
    gain makes the inclination drift; with a line ``N(i)`` rising in ``i`` the drift feeds back
    into a larger gain, and once the inclination leaves the identified range the extrapolated
    ``P(i)`` line crosses 1 and the run overflows (the real soft-neck logs: CFF-RLS in closed
    loop with a ±1° dither overestimates ``N`` two- to threefold). Clipping keeps a run finite;
    the position form, whose static gain ``N / (1 − P)`` is pinned by each operating point's
    level, keeps it close.

    One-step prediction (:meth:`predict`) uses the measured inclination ``i(t−1)``, in the rate
    form also the measured rate ``(i(t−1) − i(t−2)) / ts`` (0 at the first sample), and the
    command ``u(t−d)`` (the first command before the record starts).

    References
    ----------
    .. [1] UC3M Robotics Lab, "Model Identification of a Soft Robotic Neck", section IV and Fig. 6.
    .. [2] I. D. Landau, R. Lozano, M. M'Saad, A. Karimi, *Adaptive Control*, Springer, 2011.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid.models.scheduled.model import GainScheduledModel
    >>> i = np.array([5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0])
    >>> model = GainScheduledModel.from_points(i, -0.059 * i + 1.857, 0.01175 * i - 0.4797, ts=0.02)
    >>> np.round(model.gain_coefficients_, 4), np.round(model.pole_coefficients_, 5)
    (array([-0.059,  1.857]), array([ 0.01175, -0.4797 ]))
    >>> model.transfer_function(20.0).dt
    0.02
    >>> from neckid import IOData
    >>> command = IOData(np.full(100, 0.5), ts=0.02, input_names=["velocity_command"])
    >>> result = model.simulate(command, initial=20.0)
    >>> result.kind, result.y.shape
    ('simulation', (100, 1))
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "degree": [Interval("int", 0, None)],
        "forgetting_factor": [Interval("real", 0, 1, closed="right")],
        "segments": [None, Options(SEGMENTATIONS), Interval("int", 1, None), "array-like"],
        "skip": [Interval("int", 0, None)],
        "window": [None, Interval("int", 2, None)],
        "converged_only": ["boolean"],
        "form": [Options(FORMS)],
        "pole_bound": [Interval("real", 0, 1, closed="neither")],
    }

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        degree: int = 1,
        forgetting_factor: float = 0.98,
        segments: Literal["dwell", "bins"] | int | ArrayLike | None = DEFAULT_SEGMENTS,
        skip: int = 0,
        window: int | None = None,
        converged_only: bool = True,
        form: Form = "rate",
        pole_bound: float = DEFAULT_POLE_BOUND,
    ) -> None:
        self.lags = lags
        self.degree = degree
        self.forgetting_factor = forgetting_factor
        self.segments = segments
        self.skip = skip
        self.window = window
        self.converged_only = converged_only
        self.form = form
        self.pole_bound = pole_bound

    # ------------------------------------------------------------------ fit
    def fit(self, data: IOData | Sequence[IOData]) -> GainScheduledModel:
        """Find the operating points, identify each by CFF-RLS and fit ``N(i)``, ``P(i)``.

        Parameters
        ----------
        data : IOData or sequence of IOData
            The command (the input with a lag in ``lags``, or the one input: velocity command
            [rad/s] in the rate form, motor position [rad] in the position form) and the
            inclination [deg] (the one output). Several records are several experiments.

        Returns
        -------
        GainScheduledModel
            ``self``.

        Raises
        ------
        ValueError
            If ``lags`` is not first order (or not given, with several inputs), a segment is
            shorter than ``skip + window + 3`` samples, or fewer than ``degree + 1`` distinct
            inclinations are found.

        Warns
        -----
        UserWarning
            When fewer than ``degree + 1`` distinct inclinations converged and the lines go
            through every point (``converged_only=True``).
        """
        self._validate_params()
        experiments = as_experiments(data)
        lags = default_lags(experiments) if self.lags is None else self.lags
        if lags.conditions:
            raise ValueError(
                f"GainScheduledModel schedules its gain and pole on the inclination only; it takes"
                f" no conditions (got Lags(..., conditions={list(lags.conditions)})):"
                " identify one model per condition, or use another method"
            )
        resolved = lags.resolve(experiments)
        self._check_training(experiments)
        channel, delay = first_order_terms(resolved)
        first = experiments[0]
        segments, rule = operating_segments(
            experiments,
            self.segments,
            forgetting_factor=float(self.forgetting_factor),
            degree=int(self.degree),
        )
        points = self._identify_points(segments, channel, delay, first, "operating point")
        used = self._used(points)
        self.points_ = tuple(points)
        self._fit_lines(
            np.array([p.inclination for p, keep in zip(points, used, strict=True) if keep]),
            np.array([p.gain for p, keep in zip(points, used, strict=True) if keep]),
            np.array([p.pole for p, keep in zip(points, used, strict=True) if keep]),
        )
        self.operating_points_ = point_table(segments, points, used)
        self.segmentation_ = rule
        self.n_samples_ = int(sum(d.n_samples for d in experiments))
        self.command_unit_ = str(first.input_units[channel])
        self.lags_ = resolved
        self._set_channels(first)
        self.delay_ = delay
        self.max_lag_ = 1
        return self

    def _used(self, points: Sequence[OperatingPoint]) -> list[bool]:
        """Which points the lines go through: the converged ones, or all (with a warning)."""
        if not self.converged_only:
            return [True] * len(points)
        converged = [p.converged for p in points]
        distinct = np.unique([p.inclination for p in points if p.converged]).size
        needed = int(self.degree) + 1
        if distinct >= needed or not points:
            return converged
        warnings.warn(
            f"GainScheduledModel: {sum(converged)} of {len(points)} operating points converged"
            f" ({distinct} distinct inclinations, fewer than the {needed} a polynomial of degree"
            f" {self.degree} needs); the lines go through all {len(points)} points, converged or"
            " not (operating_points_ flags them). Longer or better excited dwells help; set"
            " converged_only=False (--set converged_only=false) to take every point silently",
            UserWarning,
            stacklevel=3,
        )
        return [True] * len(points)

    def _identify_points(
        self,
        segments: Sequence[OperatingSegment],
        channel: int,
        delay: int,
        template: IOData,
        label: str,
    ) -> list[OperatingPoint]:
        """One CFF-RLS operating point per segment, with the model's settings."""
        return identify_segments(
            segments,
            channel,
            delay,
            template,
            form=self.form,
            forgetting_factor=float(self.forgetting_factor),
            skip=int(self.skip),
            window=self.window,
            label=label,
        )

    def _fit_lines(self, i_values: FloatArray, n_values: FloatArray, p_values: FloatArray) -> None:
        degree = int(self.degree)
        distinct = np.unique(i_values).size
        if distinct < degree + 1:
            raise ValueError(
                f"a polynomial of degree {degree} needs at least {degree + 1} distinct inclinations;"
                f" got {distinct} (of {i_values.size} points): give records that hold the neck at"
                " more inclinations (or longer), other segments (--set segments=N: N equal parts"
                " of every record), or a lower degree"
            )
        self.gain_coefficients_ = np.polyfit(i_values, n_values, degree)
        self.pole_coefficients_ = np.polyfit(i_values, p_values, degree)
        self.inclinations_ = i_values
        self.gains_ = n_values
        self.poles_ = p_values
        self.schedule_range_ = np.array([i_values.min(), i_values.max()])
        self.gain_rmse_ = float(
            np.sqrt(np.mean((np.polyval(self.gain_coefficients_, i_values) - n_values) ** 2))
        )
        self.pole_rmse_ = float(
            np.sqrt(np.mean((np.polyval(self.pole_coefficients_, i_values) - p_values) ** 2))
        )

    def _bind_channels(
        self, ts: float, delay: int, input_name: str, output_name: str, output_unit: str
    ) -> None:
        ts_value = check_ts(ts)
        delay = check_number(delay, "delay", low=1, integer=True)
        template = IOData(
            np.zeros(1),
            np.zeros(1),
            ts=ts_value,
            input_names=[input_name],
            output_names=[output_name],
            output_units=[output_unit],
        )
        self.lags = Lags.arx(1, 1, delay)
        self.lags_ = self.lags.resolve(template)
        self._set_channels(template)
        self.delay_ = delay
        self.max_lag_ = 1
        self.operating_points_ = given_table(self.inclinations_, self.gains_, self.poles_)
        self.segmentation_ = "given"
        self.n_samples_ = 0
        self.command_unit_ = ""

    @classmethod
    def from_points(
        cls,
        inclinations: ArrayLike,
        gains: ArrayLike,
        poles: ArrayLike,
        *,
        ts: float,
        delay: int = 1,
        degree: int = 1,
        input_name: str = "velocity_command",
        output_name: str = "inclination",
        form: Form = "rate",
    ) -> GainScheduledModel:
        """A model whose lines ``N(i)``, ``P(i)`` are fitted to given operating points.

        Parameters
        ----------
        inclinations, gains, poles : array_like, shape (n_points,)
            Inclination [deg], ``N`` and ``P`` of each point.
        ts : float
            Sampling period [s].
        delay : int, default 1
            Input delay ``d`` [samples] the points were identified with.
        degree : int, default 1
            Polynomial degree.
        input_name, output_name : str
            Channel names of the command and the inclination.
        form : {"rate", "position"}, default "rate"
            The form the points were identified in (the seed paper's protocol,
            :func:`~neckid.identify_operating_points`, gives the rate form).
        """
        i_values = check_vector(inclinations, "inclinations")
        n_values = check_vector(gains, "gains")
        p_values = check_vector(poles, "poles")
        if not (i_values.size == n_values.size == p_values.size):
            raise ValueError(
                f"inclinations, gains and poles must have the same length; got {i_values.size},"
                f" {n_values.size} and {p_values.size}"
            )
        model = cls(degree=degree, converged_only=False, form=form)
        model._validate_params()
        model._fit_lines(i_values, n_values, p_values)
        model._bind_channels(ts, delay, input_name, output_name, "deg")
        return model

    @classmethod
    def from_coefficients(
        cls,
        gain_coefficients: ArrayLike = PAPER_GAIN_COEFFICIENTS,
        pole_coefficients: ArrayLike = PAPER_POLE_COEFFICIENTS,
        ts: float = 0.02,
        *,
        delay: int = 1,
        input_name: str = "velocity_command",
        output_name: str = "inclination",
        form: Form = "rate",
        schedule_range: ArrayLike | None = None,
    ) -> GainScheduledModel:
        """A fitted model from given polynomial coefficients (highest power first).

        The defaults are the seed paper's lines at ``ts = 0.02`` s, in its rate form.
        ``schedule_range`` (``[low, high]`` [deg]) clips the scheduling variable; default none.

        Examples
        --------
        >>> paper = GainScheduledModel.from_coefficients()
        >>> round(float(paper.gain(20.0)), 3), round(float(paper.pole(20.0)), 4)
        (0.677, -0.2447)
        """
        gain = check_vector(gain_coefficients, "gain_coefficients")
        pole = check_vector(pole_coefficients, "pole_coefficients")
        if gain.size != pole.size or gain.size == 0:
            raise ValueError(
                "gain_coefficients and pole_coefficients must be non-empty and of the same length;"
                f" got {gain.size} and {pole.size}"
            )
        limits = _schedule_limits([-np.inf, np.inf] if schedule_range is None else schedule_range)
        model = cls(degree=gain.size - 1, form=form)
        model._validate_params()
        model.schedule_range_ = limits
        model.gain_coefficients_ = gain
        model.pole_coefficients_ = pole
        model.inclinations_ = np.zeros(0)
        model.gains_ = np.zeros(0)
        model.poles_ = np.zeros(0)
        model.gain_rmse_ = math.nan
        model.pole_rmse_ = math.nan
        model._bind_channels(ts, delay, input_name, output_name, "deg")
        return model

    # ------------------------------------------------------------------ the model
    def gain(self, inclination: ArrayLike) -> FloatArray:
        """``N(s)`` at inclination(s) ``i`` [deg], ``s`` = ``i`` clipped to ``schedule_range_``."""
        check_is_fitted(self)
        return clipped_polyval(self.gain_coefficients_, inclination, self.schedule_range_)

    def pole(self, inclination: ArrayLike) -> FloatArray:
        """``P(s)`` at inclination(s) ``i`` [deg] (as :meth:`gain`), held in ``±pole_bound``."""
        check_is_fitted(self)
        bound = float(self.pole_bound)
        values = clipped_polyval(self.pole_coefficients_, inclination, self.schedule_range_)
        return np.asarray(np.clip(values, -bound, bound))

    def transfer_function(
        self, inclination: float, to: Literal["rate", "inclination"] = "rate"
    ) -> control.TransferFunction:
        """The frozen model at inclination ``i`` as a python-control ``TransferFunction`` (``dt = ts``).

        Parameters
        ----------
        inclination : float
            Operating point [deg].
        to : {"rate", "inclination"}, default "rate"
            Rate form, from the velocity command [rad/s]: ``"rate"``: ``N z^{-(d-1)} / (z − P)``
            to the inclination rate [deg/s]; ``"inclination"``: ``N · ts · z^{2-d} / ((z − P)(z − 1))``
            to the inclination [deg] (the rate integrated as ``i(t) = i(t−1) + ts · r(t)``).
            Position form, from the motor position [rad]: ``"inclination"``:
            ``N z^{-(d-1)} / (z − P)``; ``"rate"``: that times ``(z − 1) / (ts z)``, the rate
            ``(i(t) − i(t−1)) / ts``. ``d`` is ``delay_``.

        Returns
        -------
        control.TransferFunction
            Discrete-time, with ``dt`` the sampling period in seconds.
        """
        import control

        check_is_fitted(self)
        value = float(inclination)
        if not math.isfinite(value):
            raise ValueError(f"inclination must be a finite number of degrees; got {inclination!r}")
        n = float(self.gain(value))
        p = float(self.pole(value))
        extra = [0.0] * (self.delay_ - 1)  # z^{-(d-1)}: d - 1 more poles at the origin
        position = self.form == "position"
        if to == "rate" and position:
            scaled = n / self.ts_
            return control.TransferFunction([scaled, -scaled], [1.0, -p, *extra, 0.0], dt=self.ts_)
        if to == "rate" or (to == "inclination" and position):
            return control.TransferFunction([n], [1.0, -p, *extra], dt=self.ts_)
        if to == "inclination":
            return control.TransferFunction(
                [n * self.ts_, 0.0], [1.0, -(1.0 + p), p, *extra], dt=self.ts_
            )
        raise ValueError(f"to must be 'rate' or 'inclination'; got {to!r}")

    # ------------------------------------------------------------------ simulation
    def simulator(self) -> GainScheduledSimulator:
        """A stateful simulator with ``reset(y0, u0, rate0)`` and ``step(u) -> inclination``."""
        check_is_fitted(self)
        return GainScheduledSimulator(self)

    def state_map(self, bounds: bool = False) -> ScheduledStateMap:
        """The model's state functions, for python-control (:func:`neckid.export.control.to_iosystem`).

        Parameters
        ----------
        bounds : bool, default False
            Ignored (the model has no band).

        Returns
        -------
        ScheduledStateMap
            State ``[i(t−1), r(t−1), u(t−d), …, u(t−1)]``: inclination [deg], its rate
            [deg/s] and the last ``delay_`` commands.
        """
        check_is_fitted(self)
        return ScheduledStateMap(self)

    @property
    def _channel(self) -> int:
        return int(self.lags_.channel[self.lags_.source == 1][0])

    def simulate(
        self, data: IOData, initial: ArrayLike | None = None, *, rate0: float = 0.0
    ) -> ModelResult:
        """Free run from the command; the schedule follows the simulated inclination.

        Parameters
        ----------
        data : IOData
            The inputs (the command is the one with a lag in ``lags``) and, unless ``initial`` is
            given, the measured inclination whose first sample starts the run.
        initial : float or array_like of shape (1,) or (1, 1), optional
            The initial inclination [deg] (then ``data`` may hold inputs only).
        rate0 : float, default 0.0
            Initial inclination rate [deg/s] (0: the neck at rest); rate form only.

        Returns
        -------
        ModelResult
            ``kind="simulation"``, inclination [deg] in ``y``, ``n_initial = 1`` (sample 0 is the
            initial condition); ``extras`` holds ``"rate"``, ``"gain"`` and ``"pole"`` per sample.
        """
        check_is_fitted(self)
        y0 = self._initial_outputs(data, initial)
        u = data.u
        sim = GainScheduledSimulator(self)
        sim.reset(y0=y0[:1], u0=u[:1], rate0=rate0)
        n = data.n_samples
        y = np.empty(n)
        rate = np.empty(n)
        gain = np.empty(n)
        pole = np.empty(n)
        y[0], rate[0] = sim.inclination, sim.rate
        gain[0], pole[0] = math.nan, math.nan
        for t in range(1, n):
            gain[t] = sim.current_gain
            pole[t] = sim.current_pole
            y[t] = sim.step(u[t])[0]
            rate[t] = sim.rate
        return self._result(
            "simulation", data, y[:, None], extras={"rate": rate, "gain": gain, "pole": pole}
        )

    def predict(self, data: IOData) -> ModelResult:
        """One-step-ahead prediction from the measured inclination (and its rate) and the command.

        Rate form: ``î(t) = i(t−1) + ts [P(s) r(t−1) + N(s) u(t−d)]`` with the measured rate
        ``r(t−1) = (i(t−1) − i(t−2)) / ts`` (0 at ``t = 1``); position form:
        ``î(t) = P(s) i(t−1) + N(s) u(t−d)``; ``s`` is ``i(t−1)`` clipped to ``schedule_range_``.
        Commands before the record are taken equal to its first one. Sample 0 is the measured
        inclination.
        """
        check_is_fitted(self)
        self._check_inputs(data)
        if data.n_outputs == 0:
            raise ValueError("predict needs the measured inclination; data holds inputs only")
        incl = data.y[:, 0]
        u = data.u[:, self._channel]
        n = incl.size
        y = np.array(data.y, dtype=np.float64)
        if n > 1:
            previous = incl[:-1]
            rate = np.zeros(n - 1)
            rate[1:] = np.diff(previous) / self.ts_
            command = u[np.maximum(np.arange(1, n) - self.delay_, 0)]
            if self.form == "position":
                y[1:, 0] = self.pole(previous) * previous + self.gain(previous) * command
            else:
                y[1:, 0] = previous + self.ts_ * (
                    self.pole(previous) * rate + self.gain(previous) * command
                )
        return self._result("prediction", data, y)

    def _check_state(self) -> None:
        super()._check_state()
        size = np.size(self.gain_coefficients_)
        self._check_shape("gain_coefficients", self.gain_coefficients_, (size,))
        self._check_shape("pole_coefficients", self.pole_coefficients_, (size,))
        self.schedule_range_ = _schedule_limits(self.schedule_range_)
        if size < 1 or self.max_lag_ != 1 or not int(self.delay_) >= 1:
            raise ValueError(
                f"a scheduled model needs coefficients, max_lag 1 and delay >= 1; got {size}"
                f" coefficients, max_lag {self.max_lag_!r}, delay {self.delay_!r}"
            )
        first_order_terms(self.lags_)

    # ------------------------------------------------------------------ files
    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        arrays = {
            "gain_coefficients": self.gain_coefficients_,
            "pole_coefficients": self.pole_coefficients_,
            "inclinations": self.inclinations_,
            "gains": self.gains_,
            "poles": self.poles_,
            "schedule_range": self.schedule_range_,
        }
        table, kinds = table_arrays(self.operating_points_)
        arrays.update(table)
        segments = self.segments
        if isinstance(segments, int | np.integer):
            segments = int(segments)
        elif segments is not None and not isinstance(segments, str):
            segments = np.asarray(segments, dtype=np.float64).tolist()
        meta = {
            "params": {
                "degree": int(self.degree),
                "forgetting_factor": float(self.forgetting_factor),
                "segments": None if segments is None else segments,
                "skip": int(self.skip),
                "window": None if self.window is None else int(self.window),
                "converged_only": bool(self.converged_only),
                "form": str(self.form),
                "pole_bound": float(self.pole_bound),
            },
            "lags": self.lags_.to_dict(),
            "ts": self.ts_,
            "delay": self.delay_,
            "gain_rmse": self.gain_rmse_,
            "pole_rmse": self.pole_rmse_,
            "point_kinds": kinds,
            "segmentation": self.segmentation_,
            "n_samples": int(self.n_samples_),
            "command_unit": self.command_unit_,
            **self._channels_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
    ) -> GainScheduledModel:
        params = dict(meta["params"])
        params.setdefault("form", "rate")  # files written before the position form
        if "lags" not in meta:  # format-1 files of the first release: ts/input/output/delay
            model = cls.from_coefficients(
                arrays["gain_coefficients"],
                arrays["pole_coefficients"],
                float(meta["ts"]),
                delay=int(meta.get("delay", 1)),
                input_name=str(params.get("input", "velocity_command")),
                output_name=str(params.get("output", "inclination")),
                form=params["form"],
            )
            model.degree = int(params["degree"])
        else:
            model = cls(None, **params)
            model.lags_ = ResolvedLags.from_dict(meta["lags"])
            model.lags = model.lags_.to_lags()
            model._restore_channels(meta, model.lags_)
            model.ts_ = float(meta["ts"])
            model.delay_ = int(meta["delay"])
            model.max_lag_ = 1
            model.gain_coefficients_ = np.asarray(arrays["gain_coefficients"], dtype=np.float64)
            model.pole_coefficients_ = np.asarray(arrays["pole_coefficients"], dtype=np.float64)
        model.inclinations_ = np.asarray(arrays["inclinations"], dtype=np.float64)
        model.gains_ = np.asarray(arrays["gains"], dtype=np.float64)
        model.poles_ = np.asarray(arrays["poles"], dtype=np.float64)
        if "schedule_range" in arrays:
            model.schedule_range_ = np.asarray(arrays["schedule_range"], dtype=np.float64)
        else:  # files written before the clipping: the range of their points, if any
            points = model.inclinations_
            model.schedule_range_ = (
                np.array([points.min(), points.max()])
                if points.size
                else np.array([-np.inf, np.inf])
            )
        model.gain_rmse_ = float(meta["gain_rmse"])
        model.pole_rmse_ = float(meta["pole_rmse"])
        # files written before the table, the counts and the unit: the points of the lines
        model.operating_points_ = table_from_arrays(
            arrays, meta.get("point_kinds"), (model.inclinations_, model.gains_, model.poles_)
        )
        model.segmentation_ = str(meta.get("segmentation", "unknown"))
        model.n_samples_ = check_number(meta.get("n_samples", 0), "n_samples", low=0, integer=True)
        model.command_unit_ = str(meta.get("command_unit", ""))
        return model

    def partial_fit(self, data: IOData | Sequence[IOData]) -> GainScheduledModel:
        """Identify one more operating point per new experiment and refit the lines through all.

        Each experiment is one operating point, identified as in :meth:`fit` (CFF-RLS by
        :func:`identify_point` with the model's ``form``, ``forgetting_factor``, ``skip`` and
        ``window``: by default five memories of the estimator, at most half the record after
        ``skip``); it joins ``inclinations_``, ``gains_`` and ``poles_`` if it converged (or
        ``converged_only`` is False), and ``N(i)``, ``P(i)`` are fitted again through the old and
        new points, exactly as :meth:`fit` fits them (``schedule_range_`` widens with them).

        Parameters
        ----------
        data : IOData or list of IOData
            New records, each held near one inclination, on the model's channels.

        Returns
        -------
        GainScheduledModel
            ``self``; ``last_points_`` holds the new points, kept or not.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            Data on other channels, a record shorter than ``skip + window + 3`` samples, or too
            few distinct inclinations for the degree (a model from :meth:`from_coefficients`
            has no points to add one to).
        """
        from neckid.models.online import extend_training_ranges, update_experiments

        experiments = update_experiments(self, data)
        segments = [OperatingSegment((e,), -1, "experiment") for e in experiments]
        points = self._identify_points(
            segments, self._channel, self.delay_, experiments[0], "new operating point"
        )
        used = [p.converged or not self.converged_only for p in points]
        keep = [p for p, k in zip(points, used, strict=True) if k]
        if keep:
            self._fit_lines(
                np.concatenate([self.inclinations_, [p.inclination for p in keep]]),
                np.concatenate([self.gains_, [p.gain for p in keep]]),
                np.concatenate([self.poles_, [p.pole for p in keep]]),
            )
        import pandas as pd

        added = point_table(segments, points, used)
        self.operating_points_ = pd.concat([self.operating_points_, added], ignore_index=True)
        self.n_samples_ += int(sum(d.n_samples for d in experiments))
        self.points_ = (*getattr(self, "points_", ()), *points)
        self.last_points_ = tuple(points)
        extend_training_ranges(self, experiments)
        return self

    def schedule_summary(self) -> dict[str, Any]:
        """``{"schedule": describe_schedule()}``: what ``neckid info`` shows of the schedule."""
        return {"schedule": self.describe_schedule()}

    def describe_schedule(self) -> dict[str, Any]:
        """The schedule in numbers and words, as ``neckid info`` shows it (JSON-ready).

        See :func:`~neckid.models.scheduled.summary.describe_schedule`: the lines ``N(i)``,
        ``P(i)`` with their units, the schedule range, the form and the operating points.

        Examples
        --------
        >>> paper = GainScheduledModel.from_coefficients()
        >>> schedule = paper.describe_schedule()
        >>> schedule["gain"]["text"], schedule["gain"]["unit"]
        ('N(i) = -0.059 i + 1.857', '(deg/s)/(command unit)')
        """
        check_is_fitted(self)
        return describe_schedule(self)
