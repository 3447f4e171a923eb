"""Excitation signals: chirps, multisines, PRBS, random binary levels, staircases, steps, sines.

All frequencies are angular, in rad/s; all times in seconds. A signal is returned as a 1-D float64
array, one value per time stamp (or per sample), ready to be a column of an
:class:`~neckid.data.iodata.IOData`. Values carry the unit of the command they drive (the paper's
inclination commands are in degrees).

Contents
--------
- :func:`paper_chirp`, :func:`paper_chirp_frequency`: the up-chirp of the paper's eq. 14-15.
- :func:`chirp`, :func:`chirp_frequency`: a general linear chirp.
- :func:`multisine`, :func:`multisine_frequencies`: sum of sinusoids at the DFT frequencies of a band, Schroeder or random phases.
- :func:`prbs`: a maximum-length pseudo-random binary sequence held for a clock period.
- :func:`random_binary`: independent random ``±amplitude`` levels, each held ``clock`` samples.
- :func:`staircase`, :func:`step`, :func:`sine`.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal as sps

from neckid.utils.checks import (
    check_number,
    check_time_vector,
    check_ts,
)
from neckid.utils.types import FloatArray

__all__ = [
    "chirp",
    "chirp_frequency",
    "multisine",
    "multisine_frequencies",
    "paper_chirp",
    "paper_chirp_frequency",
    "prbs",
    "random_binary",
    "sine",
    "staircase",
    "step",
]


# ---------------------------------------------------------------------------------- paper chirp
def paper_chirp(
    t: ArrayLike, offset: float = 5.0, amplitude: float = 4.0, rate: float = 0.1
) -> FloatArray:
    r"""The up-chirp command of the paper's eq. 14-15: ``offset + amplitude * sin(rate * t**2)``.

    The paper writes it as ``CS = 5 + 4 sin(f t)`` with ``f = 0.1 t`` (eq. 14-15), an inclination
    command in degrees oscillating between 1° and 9° with a growing frequency.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time stamps in seconds (need not be uniform or sorted).
    offset : float, default 5.0
        The mean of the command (degrees, in the paper).
    amplitude : float, default 4.0
        The amplitude of the oscillation around ``offset`` (same unit as ``offset``).
    rate : float, default 0.1
        The paper's ``f = rate * t`` coefficient, in rad/s².

    Returns
    -------
    ndarray, shape (n_samples,)
        The command at each time stamp.

    Notes
    -----
    The phase is :math:`\phi(t) = f(t)\,t = r t^2`, so the instantaneous angular frequency is
    its derivative, :math:`\omega(t) = d\phi/dt = 2 r t`: for the paper's ``sin(0.1 t^2)`` it is
    **0.2 t rad/s, not 0.1 t**. Reading ``f = 0.1 t`` as the frequency underestimates every
    frequency by a factor of two. :func:`paper_chirp_frequency` returns the correct ``2 r t``.

    References
    ----------
    .. [1] UC3M Robotics Lab, "Model Identification of a Soft Robotic Neck", eq. 14-15.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.array([0.0, np.sqrt(np.pi / 0.2), np.sqrt(np.pi / 0.1)])
    >>> paper_chirp(t).round(12)
    array([5., 9., 5.])
    >>> paper_chirp_frequency(t).round(4)  # rad/s, 2 * 0.1 * t
    array([0.    , 0.7927, 1.121 ])
    """
    time = check_time_vector(t)
    offset_value = check_number(offset, "offset")
    amplitude_value = check_number(amplitude, "amplitude")
    rate_value = check_number(rate, "rate")
    return offset_value + amplitude_value * np.sin(rate_value * time**2)


def paper_chirp_frequency(t: ArrayLike, rate: float = 0.1) -> FloatArray:
    """Instantaneous angular frequency of :func:`paper_chirp`, ``2 * rate * t`` in rad/s.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time stamps in seconds.
    rate : float, default 0.1
        The chirp's rate in rad/s² (the paper's ``f = 0.1 t``).

    Returns
    -------
    ndarray, shape (n_samples,)
        ``d/dt (rate * t**2) = 2 * rate * t`` in rad/s (for the paper, ``0.2 t``, not ``0.1 t``).

    Examples
    --------
    >>> paper_chirp_frequency([0.0, 10.0, 50.0])
    array([ 0.,  2., 10.])
    """
    time = check_time_vector(t)
    return 2.0 * check_number(rate, "rate") * time


# ------------------------------------------------------------------------------- simple signals
def sine(
    t: ArrayLike, amplitude: float, omega: float, offset: float = 0.0, phase: float = 0.0
) -> FloatArray:
    """A sinusoid, ``offset + amplitude * sin(omega * t + phase)``.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time stamps in seconds.
    amplitude : float
        Amplitude (unit of the command).
    omega : float
        Angular frequency in rad/s (``2 pi`` times the frequency in Hz).
    offset : float, default 0.0
        Mean value.
    phase : float, default 0.0
        Phase at ``t = 0`` in radians.

    Returns
    -------
    ndarray, shape (n_samples,)

    Examples
    --------
    >>> sine([0.0, 0.25, 0.5], amplitude=2.0, omega=2 * np.pi, offset=1.0).round(12)
    array([1., 3., 1.])
    """
    time = check_time_vector(t)
    return check_number(offset, "offset") + check_number(amplitude, "amplitude") * np.sin(
        check_number(omega, "omega") * time + check_number(phase, "phase")
    )


def step(
    t: ArrayLike, amplitude: float, step_time: float = 0.0, initial: float = 0.0
) -> FloatArray:
    """A step: ``initial`` before ``step_time``, ``initial + amplitude`` from ``step_time`` on.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time stamps in seconds.
    amplitude : float
        Size of the step (unit of the command).
    step_time : float, default 0.0
        When the step happens, in seconds (the value at ``t == step_time`` is the new one).
    initial : float, default 0.0
        Value before the step.

    Returns
    -------
    ndarray, shape (n_samples,)

    Examples
    --------
    >>> step([0.0, 0.5, 1.0, 1.5], amplitude=10.0, step_time=1.0, initial=2.0)
    array([ 2.,  2., 12., 12.])
    """
    time = check_time_vector(t)
    initial_value = check_number(initial, "initial")
    amplitude_value = check_number(amplitude, "amplitude")
    return np.where(
        time >= check_number(step_time, "step_time"),
        initial_value + amplitude_value,
        initial_value,
    ).astype(np.float64)


def staircase(
    t: ArrayLike,
    step: float = 5.0,
    step_duration: float = 3.0,
    start_time: float = 0.0,
    initial: float = 0.0,
    maximum: float | None = None,
) -> FloatArray:
    """A staircase: the command climbs by ``step`` every ``step_duration`` seconds.

    The paper's inclination staircase is 5° every 3 s (the defaults).

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time stamps in seconds.
    step : float, default 5.0
        Size of each step (degrees in the paper); negative for a descending staircase.
    step_duration : float, default 3.0
        How long each level is held, in seconds, > 0.
    start_time : float, default 0.0
        Time of the first step; before it the value is ``initial``.
    initial : float, default 0.0
        Value before the first step.
    maximum : float, optional
        Where the staircase stops: the value never goes past ``maximum`` in the direction of the
        steps (for a negative ``step`` it is the lowest value). It must lie on that side of
        ``initial``.

    Returns
    -------
    ndarray, shape (n_samples,)
        ``initial + step * (floor((t - start_time) / step_duration) + 1)`` for
        ``t >= start_time``, then clipped at ``maximum``.

    Examples
    --------
    >>> staircase(np.arange(0.0, 15.0, 1.5), maximum=10.0)
    array([ 5.,  5., 10., 10., 10., 10., 10., 10., 10., 10.])
    >>> staircase([0.0, 1.0, 2.0, 3.0], step=-1.0, step_duration=1.0, start_time=1.0)
    array([ 0., -1., -2., -3.])
    """
    time = check_time_vector(t)
    step_value = check_number(step, "step")
    duration = check_number(step_duration, "step_duration", low=0, closed="neither")
    start = check_number(start_time, "start_time")
    initial_value = check_number(initial, "initial")
    # A relative tolerance keeps t = k * step_duration computed in floating point on level k.
    count = np.floor((time - start) / duration + 1e-9) + 1.0
    values = initial_value + step_value * np.where(time >= start - 1e-9 * duration, count, 0.0)
    if maximum is not None:
        limit = check_number(maximum, "maximum")
        if (step_value >= 0 and limit < initial_value) or (
            step_value < 0 and limit > initial_value
        ):
            raise ValueError(
                f"maximum must lie beyond initial={initial_value!r} in the direction of"
                f" step={step_value!r}; got {maximum!r}"
            )
        values = np.minimum(values, limit) if step_value >= 0 else np.maximum(values, limit)
    return np.asarray(values, dtype=np.float64)


# ---------------------------------------------------------------------------------------- chirp
def _chirp_duration(time: FloatArray, duration: float | None) -> float:
    if duration is None:
        end = float(time.max())
        if end <= 0:
            raise ValueError(
                "duration is None, so it is taken as the last time stamp, which must be > 0;"
                f" got {end!r}; give duration explicitly"
            )
        return end
    return check_number(duration, "duration", low=0, closed="neither")


def chirp_frequency(
    t: ArrayLike, omega_start: float, omega_end: float, duration: float | None = None
) -> FloatArray:
    """Instantaneous angular frequency of :func:`chirp`, in rad/s.

    ``omega_start + (omega_end - omega_start) * t / duration``, with ``t`` measured from 0.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time stamps in seconds.
    omega_start, omega_end : float
        Angular frequency at ``t = 0`` and at ``t = duration``, in rad/s, >= 0.
    duration : float, optional
        Seconds to sweep from ``omega_start`` to ``omega_end``; default the largest time stamp.

    Returns
    -------
    ndarray, shape (n_samples,)

    Examples
    --------
    >>> chirp_frequency([0.0, 5.0, 10.0], omega_start=1.0, omega_end=3.0)
    array([1., 2., 3.])
    """
    time = check_time_vector(t)
    start = check_number(omega_start, "omega_start")
    end = check_number(omega_end, "omega_end")
    for argument, value in (("omega_start", start), ("omega_end", end)):
        if value < 0:
            raise ValueError(f"{argument} must be >= 0 rad/s; got {value!r}")
    length = _chirp_duration(time, duration)
    return start + (end - start) * time / length


def chirp(
    t: ArrayLike,
    omega_start: float,
    omega_end: float,
    duration: float | None = None,
    amplitude: float = 1.0,
    offset: float = 0.0,
) -> FloatArray:
    r"""A linear chirp: ``offset + amplitude * sin(phi(t))``, sweeping ``omega_start .. omega_end``.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time stamps in seconds; the sweep starts at ``t = 0``.
    omega_start, omega_end : float
        Angular frequency at ``t = 0`` and at ``t = duration``, in rad/s, >= 0 (``omega_end`` may
        be the smaller one: a down-chirp). The sweep continues linearly outside ``[0, duration]``.
    duration : float, optional
        Seconds to sweep from ``omega_start`` to ``omega_end``, > 0; default the largest time
        stamp.
    amplitude : float, default 1.0
        Amplitude of the oscillation.
    offset : float, default 0.0
        Mean value.

    Returns
    -------
    ndarray, shape (n_samples,)

    Notes
    -----
    :math:`\phi(t) = \omega_0 t + \frac{\omega_1 - \omega_0}{2 T} t^2`, whose derivative is the
    instantaneous frequency :math:`\omega_0 + (\omega_1 - \omega_0) t / T`
    (:func:`chirp_frequency`). The paper's chirp (:func:`paper_chirp`) is the case
    :math:`\omega_0 = 0`, :math:`(\omega_1 - \omega_0) / T = 0.2` rad/s².

    Examples
    --------
    >>> t = np.linspace(0.0, 60.0, 601)
    >>> np.allclose(chirp(t, 0.0, 12.0, amplitude=4.0, offset=5.0), paper_chirp(t))
    True
    """
    time = check_time_vector(t)
    start = check_number(omega_start, "omega_start")
    end = check_number(omega_end, "omega_end")
    for argument, value in (("omega_start", start), ("omega_end", end)):
        if value < 0:
            raise ValueError(f"{argument} must be >= 0 rad/s; got {value!r}")
    length = _chirp_duration(time, duration)
    phase = start * time + 0.5 * (end - start) / length * time**2
    return check_number(offset, "offset") + check_number(amplitude, "amplitude") * np.sin(phase)


# ------------------------------------------------------------------------------------ multisine
def multisine_frequencies(
    period: int, ts: float, band: tuple[float, float]
) -> tuple[NDArray[np.int64], FloatArray]:
    """DFT lines of a period of ``period`` samples that fall inside ``band``.

    Parameters
    ----------
    period : int
        Samples per period, >= 2.
    ts : float
        Sampling period in seconds.
    band : (float, float)
        ``(omega_low, omega_high)`` in rad/s, ``0 <= omega_low < omega_high <= pi / ts``.

    Returns
    -------
    lines : ndarray of int
        DFT indices ``k`` (``1 <= k < period / 2``) with ``omega_low <= 2 pi k / (period ts) <=
        omega_high``.
    omegas : ndarray of float
        Their angular frequencies in rad/s.

    Examples
    --------
    >>> lines, omegas = multisine_frequencies(100, 0.01, (10.0, 30.0))
    >>> lines
    array([2, 3, 4])
    >>> omegas.round(3)
    array([12.566, 18.85 , 25.133])
    """
    n = check_number(period, "period", low=2, integer=True)
    sample_time = check_ts(ts)
    low, high = _band(band, sample_time)
    resolution = 2.0 * math.pi / (n * sample_time)
    k = np.arange(1, (n + 1) // 2, dtype=np.int64)  # excludes DC and Nyquist
    omegas = np.asarray(resolution * k, dtype=np.float64)
    inside = (omegas >= low * (1 - 1e-12)) & (omegas <= high * (1 + 1e-12))
    if not inside.any():
        raise ValueError(
            f"band=({low!r}, {high!r}) rad/s holds no DFT line of a {n}-sample period: lines are"
            f" {resolution:.4g} rad/s apart, up to {omegas[-1] if omegas.size else 0.0:.4g} rad/s;"
            " widen the band or lengthen the period"
        )
    return k[inside], omegas[inside]


def _band(band: tuple[float, float], ts: float) -> tuple[float, float]:
    try:
        low_raw, high_raw = band
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"band must be a pair (omega_low, omega_high) in rad/s; got {band!r}"
        ) from exc
    low = check_number(low_raw, "band[0]")
    high = check_number(high_raw, "band[1]")
    nyquist = math.pi / ts
    if not 0.0 <= low < high:
        raise ValueError(f"band must satisfy 0 <= omega_low < omega_high (rad/s); got {band!r}")
    if high > nyquist * (1 + 1e-12):
        raise ValueError(
            f"band[1]={high!r} rad/s is above the Nyquist frequency pi/ts={nyquist:.6g} rad/s"
        )
    return low, high


def multisine(
    n_samples: int,
    ts: float,
    band: tuple[float, float],
    amplitude: float = 1.0,
    n_periods: int = 1,
    period: int | None = None,
    seed: int | np.random.Generator | None = None,
    phases: Literal["schroeder", "random"] = "schroeder",
) -> FloatArray:
    r"""A periodic multisine: equal-amplitude cosines at every DFT line of a band.

    Parameters
    ----------
    n_samples : int
        Length of the signal in samples.
    ts : float
        Sampling period in seconds.
    band : (float, float)
        ``(omega_low, omega_high)``, the excited band in rad/s (both edges included),
        ``0 <= omega_low < omega_high <= pi / ts``. DC and the Nyquist line are never excited.
    amplitude : float, default 1.0
        Peak value of the signal (``max |x| == amplitude``), > 0.
    n_periods : int, default 1
        Number of periods in ``n_samples``; when ``period`` is None, ``n_samples`` must be a
        multiple of it and ``period = n_samples // n_periods``.
    period : int, optional
        Samples per period. The signal is that period repeated and cut at ``n_samples`` (any
        number of periods, not necessarily whole). If given with ``n_periods`` other than 1, they
        must satisfy ``n_periods * period == n_samples``.
    seed : int or numpy.random.Generator, optional
        Source of the random phases (``phases="random"`` only), passed to
        :func:`numpy.random.default_rng`.
    phases : {"schroeder", "random"}, default "schroeder"
        ``"schroeder"``: :math:`\varphi_k = -\pi k (k - 1) / F`, a low crest factor for a flat
        amplitude spectrum [1]_. ``"random"``: independent, uniform on :math:`[0, 2\pi)` [2]_.

    Returns
    -------
    ndarray, shape (n_samples,)
        :math:`x(t) = c \sum_{k=1}^{F} \cos(\omega_k t + \varphi_k)`, with :math:`\omega_k` the
        ``F`` DFT frequencies :math:`2\pi l / (P\,t_s)` of the period ``P`` inside ``band`` (see
        :func:`multisine_frequencies`), and ``c`` scaling the peak to ``amplitude``.

    Raises
    ------
    ValueError
        If no DFT line lies in the band, or the lengths do not agree.

    Notes
    -----
    Over a whole number of periods, the DFT of the signal is zero outside the band: there is no
    leakage, which is why the frequencies are DFT lines [2]_.

    References
    ----------
    .. [1] M. R. Schroeder, "Synthesis of low-peak-factor signals and binary sequences with low
       autocorrelation", IEEE Trans. Inf. Theory 16(1), 85-89, 1970.
    .. [2] R. Pintelon and J. Schoukens, *System Identification: A Frequency Domain Approach*,
       2nd ed., Wiley-IEEE Press, 2012, ch. 2.

    Examples
    --------
    >>> x = multisine(400, 0.01, band=(5.0, 40.0), amplitude=2.0, n_periods=2)
    >>> x.shape, float(np.abs(x).max())
    ((400,), 2.0)
    >>> np.allclose(x[:200], x[200:])
    True
    """
    n = check_number(n_samples, "n_samples", low=1, integer=True)
    sample_time = check_ts(ts)
    repeats = check_number(n_periods, "n_periods", low=1, integer=True)
    peak = check_number(amplitude, "amplitude", low=0, closed="neither")
    if period is None:
        if n % repeats:
            raise ValueError(
                f"n_samples={n} is not a multiple of n_periods={repeats}; give period (samples per"
                " period) to cut the signal inside a period"
            )
        length = n // repeats
    else:
        length = check_number(period, "period", low=2, integer=True)
        if repeats != 1 and repeats * length != n:
            raise ValueError(
                f"n_periods={repeats} periods of period={length} samples make {repeats * length}"
                f" samples, not n_samples={n}"
            )
    lines, _ = multisine_frequencies(length, sample_time, band)
    if phases == "schroeder":
        count = np.arange(1, lines.size + 1)
        phase = -math.pi * count * (count - 1) / lines.size
    elif phases == "random":
        phase = np.random.default_rng(seed).uniform(0.0, 2.0 * math.pi, size=lines.size)
    else:
        raise ValueError(f"phases must be 'schroeder' or 'random'; got {phases!r}")
    spectrum = np.zeros(length // 2 + 1, dtype=np.complex128)
    spectrum[lines] = np.exp(1j * phase)
    one_period = np.fft.irfft(spectrum, n=length)
    one_period *= peak / np.abs(one_period).max()
    return np.ascontiguousarray(np.resize(one_period, n), dtype=np.float64)


# ----------------------------------------------------------------------------------------- PRBS
def prbs(
    n_samples: int,
    ts: float,
    clock_period: float,
    levels: tuple[float, float] = (-1.0, 1.0),
    order: int | None = None,
    seed: int | np.random.Generator | None = None,
) -> FloatArray:
    """A pseudo-random binary sequence: a maximum-length sequence held for ``clock_period``.

    Parameters
    ----------
    n_samples : int
        Length of the signal in samples.
    ts : float
        Sampling period in seconds.
    clock_period : float
        How long each bit is held, in seconds; a whole multiple of ``ts``. A longer clock period
        moves the power to lower frequencies (the spectrum's first zero is at
        ``2 pi / clock_period`` rad/s).
    levels : (float, float), default (-1.0, 1.0)
        The values for bit 0 and bit 1.
    order : int, optional
        Number of shift-register bits, 2..32: the sequence repeats every ``2**order - 1`` bits.
        Default: the smallest order whose period covers the whole record (no repetition).
    seed : int or numpy.random.Generator, optional
        Picks a random non-zero initial register state (a circular shift of the sequence)
        through :func:`numpy.random.default_rng`. ``None`` starts from the all-ones state.

    Returns
    -------
    ndarray, shape (n_samples,)
        Each value is ``levels[0]`` or ``levels[1]``.

    Notes
    -----
    Over one period of ``N = 2**order - 1`` bits an m-sequence holds ``(N + 1) / 2`` ones, and
    its periodic autocorrelation with levels ``-1, 1`` is two-valued: ``N`` at lag 0 and ``-1`` at
    every other lag, so it is nearly white up to the clock frequency [1]_. Bits come from
    :func:`scipy.signal.max_len_seq`.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed., Prentice Hall, 1999,
       sec. 13.3.

    Examples
    --------
    >>> prbs(10, ts=0.5, clock_period=1.0, levels=(0.0, 5.0), order=3)
    array([5., 5., 5., 5., 5., 5., 0., 0., 5., 5.])
    """
    n = check_number(n_samples, "n_samples", low=1, integer=True)
    sample_time = check_ts(ts)
    clock = check_number(clock_period, "clock_period", low=0, closed="neither")
    hold = round(clock / sample_time)
    if hold < 1 or abs(hold * sample_time - clock) > 1e-6 * clock:
        raise ValueError(
            f"clock_period must be a whole multiple of ts={sample_time!r} s; got {clock_period!r} s"
        )
    try:
        low_raw, high_raw = levels
    except (TypeError, ValueError) as exc:
        raise TypeError(f"levels must be a pair (low, high); got {levels!r}") from exc
    low = check_number(low_raw, "levels[0]")
    high = check_number(high_raw, "levels[1]")
    if low == high:
        raise ValueError(f"levels must be two different values; got {levels!r}")
    n_bits = -(-n // hold)
    if order is None:
        bits = max(2, n_bits.bit_length())  # smallest b with 2**b - 1 >= n_bits
        if bits > 32:
            raise ValueError(
                f"n_samples={n} with clock_period={clock!r} s needs {n_bits} bits, more than the"
                " longest m-sequence (order 32); give order to repeat a shorter one"
            )
    else:
        bits = check_number(order, "order", low=2, high=32, integer=True)
    state = None
    if seed is not None:
        rng = np.random.default_rng(seed)
        state = rng.integers(0, 2, size=bits)
        while not state.any():
            state = rng.integers(0, 2, size=bits)
    sequence, _ = sps.max_len_seq(bits, state=state, length=n_bits)
    values = np.where(sequence.astype(bool), high, low)
    return np.ascontiguousarray(np.repeat(values, hold)[:n], dtype=np.float64)


def random_binary(
    n_samples: int,
    amplitude: float,
    clock: int = 1,
    seed: int | np.random.Generator | None = 0,
) -> FloatArray:
    """A random binary signal: ``±amplitude`` levels drawn independently, each held ``clock`` samples.

    Parameters
    ----------
    n_samples : int
        Length of the signal in samples, >= 0.
    amplitude : float
        The level (unit of the command the signal is added to; rad/s for the operating-point
        protocol's velocity excitation).
    clock : int, default 1
        Samples each level is held before the next random draw, >= 1. It sets the bandwidth:
        most of the power lies below ``1 / (2 clock ts)`` Hz.
    seed : int, numpy.random.Generator or None, default 0
        Passed to :func:`numpy.random.default_rng`; a Generator is drawn from (and advanced).

    Returns
    -------
    ndarray, shape (n_samples,)
        Each value is ``-amplitude`` or ``+amplitude``.

    Notes
    -----
    Unlike :func:`prbs`, the levels are independent fair coin flips
    (``numpy.random.Generator.integers(0, 2)``, one per clock period), not a maximum-length
    sequence: the signal does not repeat and its autocorrelation is two-valued only on average.
    This is the excitation of the seed paper's operating-point protocol
    (:func:`neckid.loops.operating_points.identify_operating_points`).

    Examples
    --------
    >>> x = random_binary(8, 0.5, clock=2, seed=1)
    >>> sorted(set(x.tolist())) in ([-0.5, 0.5], [-0.5], [0.5])
    True
    >>> bool(np.all(x[0::2] == x[1::2]))
    True
    """
    n = check_number(n_samples, "n_samples", low=0, integer=True)
    hold = check_number(clock, "clock", low=1, integer=True)
    level = check_number(amplitude, "amplitude")
    rng = np.random.default_rng(seed)
    levels = rng.integers(0, 2, size=-(-n // hold)) * 2.0 - 1.0
    return np.asarray(level * np.repeat(levels, hold)[:n], dtype=np.float64)
