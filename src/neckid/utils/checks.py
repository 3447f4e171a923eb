"""One place for input checks: hyper-parameter constraints, numbers, lags, arrays and time vectors.

Every estimator declares its hyper-parameters once, in the scikit-learn style, as a class
attribute ``_parameter_constraints`` mapping each ``__init__`` argument to a list of accepted
forms; :func:`validate_parameters` checks them all at the start of ``fit`` (constructors only
store their arguments). The other functions are the value checks the rest of the package shares,
so that a message always names the argument, the rule and the value it got.

Accepted forms in a constraint list:

- ``None``: the value may be ``None``;
- ``"boolean"``: ``True`` / ``False`` (NumPy booleans too);
- ``"array-like"``: anything :func:`numpy.asarray` turns into a finite float array;
- ``"lag-list"``: a sequence of whole numbers ``>= 0`` without repeats (``[0, 1, 2]``);
- ``"layer-sizes"``: a non-empty sequence of whole numbers ``>= 1`` (``(25, 25)``);
- ``"callable"``: a function or any callable object;
- ``"random_state"``: ``None``, an ``int >= 0`` or a :class:`numpy.random.Generator`;
- an :class:`Interval` (a real or whole number in a range), an :class:`Options` (one of given
  values), or a type (an instance of it, e.g. :class:`~neckid.Lags`).

References
----------
scikit-learn's ``utils/_param_validation.py`` (the declarative pattern; written anew here so that
neckid does not depend on scikit-learn's private API).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from neckid.utils.types import FloatArray

__all__ = [
    "Interval",
    "Options",
    "check_finite",
    "check_lag_list",
    "check_number",
    "check_time_vector",
    "check_ts",
    "check_uniform_time",
    "check_vector",
    "per_output",
    "validate_parameters",
]


# ---------------------------------------------------------------------------- constraints
@dataclass(frozen=True)
class Interval:
    """A real (``kind="real"``) or whole (``kind="int"``) number between ``low`` and ``high``.

    ``None`` for a bound means unbounded on that side; ``closed`` says which ends belong to the
    interval (``"both"``, ``"left"``, ``"right"`` or ``"neither"``). NaN and infinities are
    always refused.

    Examples
    --------
    >>> Interval("real", 0, 1, closed="right").describe()
    'a number in (0, 1]'
    >>> Interval("int", 1, None).describe()
    'a whole number >= 1'
    """

    kind: Literal["real", "int"]
    low: float | None
    high: float | None
    closed: Literal["both", "left", "right", "neither"] = "both"

    def accepts(self, value: Any) -> bool:
        """Whether ``value`` is a number of the right kind inside the interval."""
        if isinstance(value, bool | np.bool_):
            return False
        if self.kind == "int":
            if not isinstance(value, numbers.Integral):
                return False
        elif not isinstance(value, numbers.Real):
            return False
        number = float(value)
        if not math.isfinite(number):
            return False
        left_closed = self.closed in ("both", "left")
        right_closed = self.closed in ("both", "right")
        if self.low is not None and (number < self.low or (number == self.low and not left_closed)):
            return False
        above = self.high is not None and (
            number > self.high or (number == self.high and not right_closed)
        )
        return not above

    def describe(self) -> str:
        """The rule in words, for error messages."""
        noun = "a whole number" if self.kind == "int" else "a number"
        if self.low is not None and self.high is not None:
            left = "[" if self.closed in ("both", "left") else "("
            right = "]" if self.closed in ("both", "right") else ")"
            return f"{noun} in {left}{self.low:g}, {self.high:g}{right}"
        if self.low is not None:
            op = ">=" if self.closed in ("both", "left") else ">"
            return f"{noun} {op} {self.low:g}"
        if self.high is not None:
            op = "<=" if self.closed in ("both", "right") else "<"
            return f"{noun} {op} {self.high:g}"
        return "a finite number" if self.kind == "real" else noun


@dataclass(frozen=True)
class Options:
    """One of a fixed set of values (strings, usually)."""

    values: Collection[Any]

    def accepts(self, value: Any) -> bool:
        """Whether ``value`` is one of the options."""
        if isinstance(value, np.ndarray):  # `in` would compare element-wise
            return False
        try:
            return value in self.values
        except TypeError:  # unhashable value against a set
            return False

    def describe(self) -> str:
        """The rule in words, for error messages."""
        return "one of " + ", ".join(repr(v) for v in self.values)


def _accepts(constraint: Any, value: Any) -> bool:
    if constraint is None:
        return value is None
    if isinstance(constraint, Interval | Options):
        return constraint.accepts(value)
    if isinstance(constraint, type):
        return isinstance(value, constraint)
    if constraint == "boolean":
        return isinstance(value, bool | np.bool_)
    if constraint == "callable":
        return callable(value)
    if constraint == "random_state":
        return (
            value is None
            or isinstance(value, np.random.Generator)
            or (Interval("int", 0, None).accepts(value))
        )
    if constraint == "lag-list":
        try:
            check_lag_list(value, "value")
        except (TypeError, ValueError):
            return False
        return True
    if constraint == "layer-sizes":
        return (
            isinstance(value, Sequence)
            and not isinstance(value, str)
            and len(value) > 0
            and all(Interval("int", 1, None).accepts(v) for v in value)
        )
    if constraint == "array-like":
        if isinstance(value, str | bytes | Mapping) or value is None:
            return False
        try:
            array = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            return False
        return bool(array.size == 0 or np.all(np.isfinite(array)))
    raise ValueError(f"unknown parameter constraint {constraint!r}")  # pragma: no cover


def _describe(constraint: Any) -> str:
    if constraint is None:
        return "None"
    if isinstance(constraint, Interval | Options):
        return constraint.describe()
    if isinstance(constraint, type):
        return f"a {constraint.__module__.split('.')[0]}.{constraint.__name__}"
    return {
        "boolean": "True or False",
        "callable": "a callable",
        "random_state": "None, an int >= 0 or a numpy Generator",
        "lag-list": "a list of whole-number lags >= 0 without repeats",
        "layer-sizes": "a non-empty tuple of whole numbers >= 1",
        "array-like": "an array of finite numbers",
    }[constraint]


def validate_parameters(estimator: Any) -> None:
    """Check every hyper-parameter of ``estimator`` against its ``_parameter_constraints``.

    Raises
    ------
    TypeError
        When no accepted form has the value's type (a string where a number is expected).
    ValueError
        When the type is right but the value is out of range; the message names the parameter,
        every accepted form and the value, e.g. ``"forgetting_factor must be a number in (0, 1];
        got 1.2"``.
    """
    constraints: Mapping[str, Sequence[Any]] = type(estimator)._parameter_constraints
    for name, value in estimator.get_params(deep=False).items():
        accepted = constraints.get(name)
        if accepted is None:
            raise RuntimeError(  # pragma: no cover - a developer error, caught by the tests
                f"{type(estimator).__name__}.{name} has no entry in _parameter_constraints"
            )
        rule = " or ".join(_describe(c) for c in accepted)
        if _beyond_int64(value):  # compiled code and NumPy would overflow on it, or round it
            digits = len(str(abs(int(value))))
            raise ValueError(
                f"{name} must be {rule}; got a whole number of {digits} digits, beyond 2**63"
                " (what NumPy and compiled code hold)"
            )
        try:
            accepted_here = any(_accepts(c, value) for c in accepted)
        except OverflowError:
            accepted_here = False
        if accepted_here:
            continue
        raise (ValueError if _right_type(accepted, value) else TypeError)(
            f"{name} must be {rule}; got {value!r:.80}"
        )


def _beyond_int64(value: Any) -> bool:
    """Whether ``value`` is a Python whole number (not a bool) beyond the int64 range."""
    return (
        isinstance(value, numbers.Integral)
        and not isinstance(value, bool | np.bool_)
        and not -(2**63) <= int(value) < 2**63
    )


def _right_type(accepted: Sequence[Any], value: Any) -> bool:
    """Whether ``value`` has the type of some accepted form (so a wrong value, not a wrong type)."""
    number = isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)
    for constraint in accepted:
        if isinstance(constraint, Interval) and number:
            return True
        if isinstance(constraint, Options) and any(
            type(value) is type(v) for v in constraint.values
        ):
            return True
        sequence = isinstance(value, Sequence | np.ndarray) and not isinstance(value, str)
        whole = sequence and all(
            isinstance(v, numbers.Integral) and not isinstance(v, bool | np.bool_) for v in value
        )
        if (constraint == "array-like" and sequence) or (
            constraint in ("lag-list", "layer-sizes") and whole
        ):
            return True
    return False


# ---------------------------------------------------------------------------- values
def check_number(
    value: Any,
    argument: str,
    *,
    low: float | None = None,
    high: float | None = None,
    closed: Literal["both", "left", "right", "neither"] = "both",
    integer: bool = False,
) -> Any:
    """Return ``value`` as a float (or int with ``integer=True``) after checking its range.

    Raises ``TypeError`` for a non-number (booleans included) and ``ValueError`` for NaN, an
    infinity or a value outside the range, naming ``argument`` and the value.

    Examples
    --------
    >>> check_number(3, "clock", low=1, integer=True)
    3
    >>> check_number(0.0, "ts", low=0, closed="neither")
    Traceback (most recent call last):
    ...
    ValueError: ts must be a number > 0; got 0.0
    """
    interval = Interval("int" if integer else "real", low, high, closed)
    if isinstance(value, bool | np.bool_) or not isinstance(
        value, numbers.Integral if integer else numbers.Real
    ):
        raise TypeError(f"{argument} must be {interval.describe()}; got {value!r}")
    if not math.isfinite(float(value)) or not interval.accepts(value):
        raise ValueError(f"{argument} must be {interval.describe()}; got {value!r}")
    number: Any = value  # an Integral or a Real, checked above
    return int(number) if integer else float(number)


#: The longest sampling period accepted, in seconds (11.6 days): a larger ts is a unit mistake
#: (nanoseconds or a time stamp taken for seconds), not a log.
LARGEST_TS = 1e6


def check_ts(ts: Any) -> float:
    """Return the sampling period as a float, refusing what is not a positive finite number.

    A real number (NumPy's too, or a 0-d array of one) in ``(0, 1e6]`` seconds; booleans, text
    and complex numbers are refused.

    Examples
    --------
    >>> check_ts(0.02)
    0.02
    >>> check_ts(True)
    Traceback (most recent call last):
    ...
    TypeError: ts must be a number of seconds; got True
    """
    if isinstance(ts, np.ndarray) and ts.ndim == 0:
        ts = ts[()]
    if isinstance(ts, bool | np.bool_) or not isinstance(ts, numbers.Real):
        raise TypeError(f"ts must be a number of seconds; got {ts!r}")
    try:
        value = float(ts)
    except OverflowError:  # a Python integer beyond the float range
        value = math.inf
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"ts must be a positive number of seconds; got {value!r}")
    if value > LARGEST_TS:
        raise ValueError(
            f"ts must be a positive number of seconds at most {LARGEST_TS:g} (11.6 days); got"
            f" {value!r}: is it in another unit (ns, ms) or a time stamp?"
        )
    return value


def check_finite(array: FloatArray, argument: str, names: Sequence[str] | None = None) -> None:
    """Raise ``ValueError`` naming the channel, the row and the value of the first NaN or inf.

    Parameters
    ----------
    array : ndarray, shape (n_samples, n_channels)
        The values to check.
    argument : str
        What the array is called in the message (``"u"``, ``"y"``, ``"commands"``).
    names : sequence of str, optional
        Channel names, one per column.
    """
    bad = ~np.isfinite(array)
    if bad.any():
        row, col = (int(i) for i in np.argwhere(bad)[0])
        channel = names[col] if names is not None and col < len(names) else f"column {col}"
        count = int(bad.sum())
        raise ValueError(
            f"{argument} channel {channel!r} has a non-finite value {float(array[row, col])!r} at row {row}"
            f" ({count} non-finite value{'s' if count > 1 else ''} in {argument} in all);"
            " clean or interpolate the log before identification"
        )


def check_vector(values: ArrayLike, argument: str) -> FloatArray:
    """Return ``values`` as a 1-D finite float64 array (scalars become one-element arrays).

    Raises ``TypeError`` when the values are not numbers and ``ValueError`` (naming the row) for a
    2-D array or a NaN/inf.
    """
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{argument} must be numeric; could not convert it: {exc}") from exc
    if array.ndim == 0:
        array = array.reshape(1)
    if array.ndim != 1:
        raise ValueError(f"{argument} must be 1-D (one value per sample); got shape {array.shape}")
    bad = np.flatnonzero(~np.isfinite(array))
    if bad.size:
        raise ValueError(
            f"{argument} has a non-finite value {float(array[bad[0]])!r} at row {bad[0]}"
        )
    return np.ascontiguousarray(array)


def check_time_vector(t: ArrayLike, argument: str = "t", *, increasing: bool = False) -> FloatArray:
    """A time vector [s]: 1-D, finite and, with ``increasing``, strictly increasing.

    Raises ``ValueError`` naming the first row that breaks the rule.
    """
    array = check_vector(t, argument)
    if increasing and array.size > 1:
        back = np.flatnonzero(np.diff(array) <= 0)
        if back.size:
            row = int(back[0]) + 1
            raise ValueError(
                f"{argument} must increase strictly; row {row} has {array[row]!r} after"
                f" {array[row - 1]!r}"
            )
    return array


def check_lag_list(value: Any, argument: str, minimum: int = 0) -> tuple[int, ...]:
    """A sequence of whole-number lags ``>= minimum`` without repeats, returned sorted.

    Booleans and non-whole numbers are refused (``[True]`` is not lag 1).

    Examples
    --------
    >>> check_lag_list([2, 0, 1], "linear_lags")
    (0, 1, 2)
    """
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence | np.ndarray):
        raise TypeError(f"{argument} must be a list of whole numbers; got {value!r}")
    lags: list[int] = []
    for item in value:
        if isinstance(item, bool | np.bool_) or not isinstance(item, numbers.Integral):
            raise TypeError(f"{argument} must hold whole numbers; got {item!r} in {list(value)}")
        lags.append(int(item))
    bad = [v for v in lags if v < minimum]
    if bad:
        raise ValueError(f"{argument} must hold lags >= {minimum}; got {bad[0]} in {lags}")
    if len(set(lags)) != len(lags):
        raise ValueError(f"{argument} repeats a lag: {lags}")
    return tuple(sorted(lags))


# ---------------------------------------------------------------------------- time stamps
#: Relative tolerance on the spacing of time stamps before a log counts as non-uniform.
TIME_JITTER_TOLERANCE = 0.05


def check_uniform_time(
    time: ArrayLike,
    column: str = "time",
    *,
    ts: float | None = None,
    allow_repeats: bool = False,
) -> tuple[float, float]:
    """Check that time stamps are uniformly sampled; return the sampling period and the start.

    Parameters
    ----------
    time : array_like, shape (n_samples,)
        Time stamps in seconds, one per sample.
    column : str, default "time"
        What the stamps are called in messages (a table's column, or an argument such as ``"t"``).
    ts : float, optional
        The sampling period in seconds every step must match; by default the median step.
    allow_repeats : bool, default False
        Accept a step of zero (a stamp repeating the one before, as in logs whose clock restarts
        between segments); the caller decides what to do with those rows.

    Returns
    -------
    ts : float
        The given ``ts``; otherwise the mean step ``(t[-1] - t[0]) / (n_samples - 1)``, the
        least-squares period of a uniform grid, or, with ``allow_repeats``, the median of the
        positive steps (a mean would count the repeated stamps).
    t0 : float
        The first time stamp, in seconds.

    Raises
    ------
    TypeError
        If the stamps are not numbers.
    ValueError
        Naming ``column`` and the first row (index into ``time``) that breaks a rule: fewer
        than two stamps, a NaN or inf, time going back, a repeated stamp (unless
        ``allow_repeats``), the same stamp on every row, or a step that departs from the period
        by more than :data:`TIME_JITTER_TOLERANCE` (5 %) of it (a gap or jitter). Also if ``ts``
        is given and is not a positive number of seconds.

    Examples
    --------
    >>> check_uniform_time([2.0, 2.25, 2.5, 2.75])
    (0.25, 2.0)
    >>> check_uniform_time([0.0, 0.1, 0.2, 0.4, 0.5], column="t")
    Traceback (most recent call last):
    ...
    ValueError: time column 't' is not uniformly sampled: the step before row 3 is 0.2 s ...
    """
    t = check_vector(time, f"time column {column!r}")
    if t.size < 2:
        raise ValueError(
            f"time column {column!r} needs at least 2 time stamps to give a sampling period;"
            f" got {t.size}"
        )
    period = None if ts is None else check_ts(ts)
    dt = np.diff(t)
    back = np.flatnonzero(dt < 0)
    if back.size:
        r = int(back[0]) + 1
        raise ValueError(
            f"time column {column!r} is not sorted: row {r} has t={float(t[r])!r} after"
            f" t={float(t[r - 1])!r}; sort the log by time first"
        )
    repeated = dt == 0
    if repeated.any() and not allow_repeats:
        r = int(np.flatnonzero(repeated)[0]) + 1
        raise ValueError(
            f"time column {column!r} repeats the time stamp {float(t[r])!r} at rows {r - 1} and"
            f" {r}; drop duplicated samples first"
        )
    if repeated.all():
        raise ValueError(
            f"time column {column!r} has the same time stamp {float(t[0])!r} on every row;"
            " it gives no sampling period"
        )
    reference = float(np.median(dt[~repeated])) if period is None else period
    off = np.flatnonzero(~repeated & (np.abs(dt - reference) > TIME_JITTER_TOLERANCE * reference))
    if off.size:
        r = int(off[0]) + 1
        rule = "the median step" if period is None else "ts"
        raise ValueError(
            f"time column {column!r} is not uniformly sampled: the step before row {r} is"
            f" {float(dt[r - 1]):.6g} s (t={float(t[r - 1]):g} -> {float(t[r]):g} s) where {rule}"
            f" is {reference:.6g} s, more than {TIME_JITTER_TOLERANCE:.0%} away; resample the"
            " log onto a uniform grid first"
        )
    if period is None:
        # The mean step is the least-squares estimate of ts from a uniform grid; with repeated
        # stamps it would count the repeats as samples, so the median step is kept instead.
        period = reference if allow_repeats else float((t[-1] - t[0]) / (t.size - 1))
    return period, float(t[0])


def per_output(value: Any, n_outputs: int, argument: str) -> FloatArray:
    """A scalar or one value per output, as finite float64 of shape (n_outputs,)."""
    if isinstance(value, bool):
        raise TypeError(f"{argument} must be a number or one number per output; got {value!r}")
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"{argument} must be a number or one number per output; got {value!r}"
        ) from exc
    if array.ndim == 0:
        array = np.full(n_outputs, float(array))
    if array.shape != (n_outputs,):
        raise ValueError(
            f"{argument} must be a number or {n_outputs} numbers (one per output); got shape"
            f" {array.shape}"
        )
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{argument} must be finite; got {array.tolist()}")
    return array
