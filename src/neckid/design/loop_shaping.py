r"""Loop shaping on a linear form: margins, and the gains that meet a phase margin at a crossover.

The loop is :math:`L(e^{j\omega T}) = C(e^{j\omega T})\,G(e^{j\omega T})\,e^{-j\omega T d}` with
:math:`C = k_p + k_f D` (:mod:`neckid.design.operators`: :math:`D` the Tustin integrator for a PI,
:math:`s^\alpha` realised by the lab's Grünwald–Letnikov sum or Oustaloup's filter for a
fractional PI\ :sup:`λ` (:math:`\alpha < 0`) or PD\ :sup:`μ` (:math:`\alpha > 0`)). The
specifications at the crossover :math:`\omega_c` with phase margin :math:`\varphi_m`
(Monje, Chen, Vinagre, Xue and Feliu, 2010, sec. 9.2):

.. math::

    |L(j\omega_c)| = 1, \qquad \arg L(j\omega_c) = -\pi + \varphi_m, \qquad
    \left.\frac{d \arg L(j\omega)}{d\omega}\right|_{\omega_c} = 0 \ \text{(iso-damping)}.

The first two are one complex equation, :math:`k_p + k_f D(j\omega_c) = c :=
e^{j(-\pi + \varphi_m)}/(G(j\omega_c)e^{-j\omega_c T d})`, *linear* in the gains for a given
operator, so they are met exactly by

.. math:: k_f = \frac{\operatorname{Im} c}{\operatorname{Im} D(j\omega_c)}, \qquad
          k_p = \operatorname{Re} c - k_f \operatorname{Re} D(j\omega_c)

(evaluated on the realised discrete operator, so the margins hold for the controller that
runs, not for its continuous ideal). A PI has no third parameter: it meets the first two. A
fractional controller chooses its order :math:`\alpha` for the third: with the ideal
:math:`D = s^\alpha`, :math:`x = k_f\omega^\alpha/k_p`, the controller's phase slope is

.. math:: \frac{d\arg C}{d\omega} = \frac{\alpha\,x \sin(\alpha\pi/2)}
          {\omega\,(1 + 2x\cos(\alpha\pi/2) + x^2)},

which must cancel the plant's :math:`d\arg G/d\omega` at :math:`\omega_c` (the lab's tuner
reads the same condition from a table). Here the slope of the whole realised loop is computed
(central difference) and the order found by Brent's method on a scan of (−1, 0) and (0, 1),
keeping orders with positive gains; among several roots the one with the smallest sensitivity
peak :math:`M_s = \max_\omega |1/(1 + L)|`. When no order flattens the phase (the plant's slope
is steeper than any fractional integral that adds so little phase can cancel, or the lab's
truncated sum is used, whose phase is not :math:`\alpha\pi/2`), the order with the flattest
phase is kept and the design says so (``flat=False``).

References
----------
- C. A. Monje, Y. Q. Chen, B. M. Vinagre, D. Xue, V. Feliu, *Fractional-order Systems and
  Controls: Fundamentals and Applications*, Springer, 2010, ch. 9 (tuning PI\ :sup:`λ`D\ :sup:`μ`
  for phase margin, crossover and robustness to gain variations).
- C. A. Monje, B. M. Vinagre, V. Feliu, Y. Q. Chen, "Tuning and auto-tuning of fractional order
  controllers for industry applications", *Control Engineering Practice* 16 (7), 2008.
- ``shared/data/softneck/CONTROLLERS.md`` ("ada": the lab's 50° at 3 rad/s with a flat phase).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from neckid.design.controllers import DesignedController
from neckid.design.linear_form import LinearForm
from neckid.design.operators import (
    DISCRETISATIONS,
    GL_THRESHOLD,
    DiscreteOperator,
    default_band,
    grunwald_letnikov_operator,
    oustaloup_operator,
    tustin_integrator,
)
from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = [
    "Design",
    "DesignSpec",
    "LoopMargins",
    "closed_loop_stable",
    "design_fractional",
    "design_pi",
    "ideal_iso_damping",
    "loop_margins",
    "phase_slope",
    "solve_gains",
]

Response = Callable[[ArrayLike], np.ndarray]

#: A loop's phase is flat when its slope at the crossover is below this, deg per rad/s.
FLAT_TOLERANCE = 0.01

_ORDERS = np.round(np.concatenate([np.arange(-0.99, 0.0, 0.01), np.arange(0.01, 1.0, 0.01)]), 2)


@dataclass(frozen=True)
class DesignSpec:
    """What a design asks for.

    Attributes
    ----------
    phase_margin : float
        Degrees.
    crossover : float
        rad/s.
    flat_phase : bool
        Whether the phase must be flat at the crossover (iso-damping; fractional designs).
    """

    phase_margin: float = 50.0
    crossover: float = 3.0
    flat_phase: bool = True


@dataclass(frozen=True)
class LoopMargins:
    r"""Margins of a loop :math:`L = C G e^{-j\\omega T d}` and how robust it is.

    Attributes
    ----------
    phase_margin : float
        Degrees, at :attr:`crossover` (the lowest of the smallest over every gain crossover).
    crossover : float
        The first gain crossover (where :math:`|L|` falls through 1), rad/s.
    gain_margin : float
        :math:`1/|L|` where the phase crosses −180° (inf if it never does).
    phase_slope : float
        :math:`d\\arg L/d\\omega` at the crossover, deg per rad/s (0: iso-damping).
    sensitivity_peak : float
        :math:`M_s = \\max_\\omega |1/(1 + L)|` up to the Nyquist frequency.
    stable : bool
        Whether the closed loop's poles are inside the unit circle (None when not computed).
    """

    phase_margin: float
    crossover: float
    gain_margin: float
    phase_slope: float
    sensitivity_peak: float
    stable: bool | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready, with units in the keys."""
        return {
            "phase_margin_deg": self.phase_margin,
            "crossover_rad_s": self.crossover,
            "gain_margin": self.gain_margin if math.isfinite(self.gain_margin) else None,
            "phase_slope_deg_per_rad_s": self.phase_slope,
            "sensitivity_peak": self.sensitivity_peak,
            "closed_loop_stable": self.stable,
        }


def _grid(form: LinearForm, crossover: float) -> FloatArray:
    nyquist = math.pi / form.ts
    return np.geomspace(min(crossover, nyquist) / 1000.0, 0.999 * nyquist, 4000)


def _wrapped_margin(value: complex) -> float:
    """``180 + arg`` with the phase taken in [−180°, 180°): the margin in (−180, 180]."""
    phase = math.degrees(math.atan2(value.imag, value.real))
    return 180.0 + ((phase + 180.0) % 360.0 - 180.0) if phase != 180.0 else 0.0


def phase_slope(loop: Response, omega: float) -> float:
    r""":math:`d\\arg L/d\\omega` at ``omega`` by a central difference, deg per rad/s."""
    h = 1e-4 * omega
    ratio = complex(loop(omega + h)) / complex(loop(omega - h))
    return math.degrees(math.atan2(ratio.imag, ratio.real) / (2.0 * h))


def loop_margins(form: LinearForm, controller: Response, crossover: float = 3.0) -> LoopMargins:
    r"""The margins of :math:`C G e^{-j\omega T d}` for a controller's frequency response.

    Parameters
    ----------
    form : LinearForm
        The plant and the loop's delay.
    controller : callable
        :math:`\omega \mapsto C(e^{j\omega T})` (a designed controller's ``response``).
    crossover : float, default 3
        Where to centre the frequency grid, rad/s (the grid spans 1/1000 of it to Nyquist).

    Returns
    -------
    LoopMargins
        ``stable`` is None (see :func:`neckid.design.controllers.closed_loop_stable`).
    """
    from scipy.optimize import brentq

    def loop(w: ArrayLike) -> np.ndarray:
        return np.asarray(controller(w)) * form.response(w)

    grid = _grid(form, crossover)
    values = loop(grid)
    log_gain = np.log(np.abs(values))
    changes = np.flatnonzero(np.sign(log_gain[:-1]) != np.sign(log_gain[1:]))
    if not changes.size:
        return LoopMargins(math.inf, math.nan, math.nan, math.nan, _peak(values))
    crossings = [
        brentq(lambda w: math.log(abs(complex(loop(w)))), grid[i], grid[i + 1], xtol=1e-12)
        for i in changes
    ]
    falling = [w for w, i in zip(crossings, changes, strict=True) if log_gain[i] > 0]
    first = falling[0] if falling else crossings[0]
    margins = [_wrapped_margin(complex(loop(w))) for w in crossings]
    angle = np.angle(values)
    # Phase crossovers: the wrapped phase passes through ±180° (a jump of about 2π).
    jumps = np.flatnonzero(np.abs(np.diff(angle)) > math.pi)
    gains = [1.0 / abs(values[i]) for i in jumps if abs(values[i]) < 1.0]
    return LoopMargins(
        phase_margin=float(min(margins)),
        crossover=float(first),
        gain_margin=float(min(gains)) if gains else math.inf,
        phase_slope=phase_slope(loop, first),
        sensitivity_peak=_peak(values),
    )


def _peak(values: np.ndarray) -> float:
    return float(np.max(1.0 / np.abs(1.0 + values)))


def solve_gains(
    form: LinearForm, operator_at_crossover: complex, phase_margin: float, crossover: float
) -> tuple[float, float]:
    r"""The gains :math:`(k_p, k_f)` of :math:`k_p + k_f D` that meet the margin at the crossover.

    Parameters
    ----------
    form : LinearForm
        The plant and the loop's delay.
    operator_at_crossover : complex
        :math:`D(e^{j\omega_c T})`.
    phase_margin : float
        Degrees.
    crossover : float
        rad/s.

    Returns
    -------
    (float, float)
        :math:`k_p`, :math:`k_f` (either may be negative: the caller checks).

    Raises
    ------
    ValueError
        If :math:`D(j\omega_c)` is real (the operator adds no phase: no solution).
    """
    g = complex(form.response(crossover))
    target = complex(math.cos(math.radians(-180.0 + phase_margin)), 0.0)
    target += 1j * math.sin(math.radians(-180.0 + phase_margin))
    c = target / g
    d = complex(operator_at_crossover)
    if abs(d.imag) < 1e-12 * max(abs(d), 1e-300):
        raise ValueError(
            "the operator's response at the crossover is real: no gains give the phase"
        )
    kf = c.imag / d.imag
    return c.real - kf * d.real, kf


@dataclass(frozen=True)
class Design:
    r"""A designed controller's numbers, the plant it was designed on and what it achieves there.

    Attributes
    ----------
    kind : {"pi", "fractional"}
    kp : float
        Proportional gain, (rad/s)/deg.
    kf : float
        Gain of the operator: :math:`k_i` of a PI [(rad/s)/(deg s)], or of :math:`s^\\alpha`.
    operator : DiscreteOperator
        The realised operator (Tustin integrator, GL sum or Oustaloup filter).
    form : LinearForm
        The plant.
    spec : DesignSpec
    margins : LoopMargins
        Achieved on ``form`` by the realised controller.
    flat : bool
        Whether the realised loop's phase is flat at the crossover (slope below 0.01 deg per
        rad/s; False for a PI, which has no order to flatten it with).
    order_rule : str
        How the order was chosen: ``"realised loop flat"`` (or ``"... flattest"`` when no order
        flattens it), ``"ideal s^alpha flat"`` / ``"... flattest"`` (the GL sum: the order
        from the continuous operator, as the lab's tuner takes it), or ``"fixed"``.
    """

    kind: Literal["pi", "fractional"]
    kp: float
    kf: float
    operator: DiscreteOperator
    form: LinearForm
    spec: DesignSpec
    margins: LoopMargins
    flat: bool
    order_rule: str = ""

    @property
    def order(self) -> float:
        """The operator's order (−1 for the PI's integrator)."""
        return self.operator.order

    def response(self, omega: ArrayLike) -> np.ndarray:
        r"""The controller's frequency response :math:`k_p + k_f D(e^{j\\omega T})`."""
        return self.kp + self.kf * self.operator.response(omega)

    def controller(
        self, *, command_limit: float | None = None, model: dict[str, Any] | None = None
    ) -> DesignedController:
        """The designed controller, carrying this design's summary (and the model's description).

        Parameters
        ----------
        command_limit : float, optional
            Saturation of the command, rad/s, with conditional integration.
        model : dict, optional
            What the model was (path, digest, class), for the controller file.

        Returns
        -------
        DesignedController
        """
        info = {**self.summary(), "plant": self.form.to_dict()}
        if model is not None:
            info["model"] = model
        return DesignedController(
            self.kp, self.kf, self.operator, command_limit=command_limit, info=info
        )

    def summary(self) -> dict[str, Any]:
        """JSON-ready: kind, gains, order, spec, achieved margins, flat."""
        return {
            "kind": self.kind,
            "kp": self.kp,
            "kf": self.kf,
            "order": self.order,
            "spec": asdict(self.spec),
            "achieved": self.margins.to_dict(),
            "flat_phase_reached": self.flat,
            "order_rule": self.order_rule,
        }


def _checked_spec(phase_margin: float, crossover: float, form: LinearForm) -> tuple[float, float]:
    pm = check_number(phase_margin, "phase_margin", low=0, high=180, closed="neither")
    wc = check_number(crossover, "crossover", low=0, closed="neither")
    if wc >= math.pi / form.ts:
        raise ValueError(
            f"crossover must be below the Nyquist frequency {math.pi / form.ts:.4g} rad/s of"
            f" ts={form.ts} s; got {wc}"
        )
    return pm, wc


def _finish(
    kind: Literal["pi", "fractional"],
    gains: tuple[float, float],
    operator: DiscreteOperator,
    form: LinearForm,
    spec: DesignSpec,
    flat: bool,
    rule: str,
) -> Design:
    kp, kf = gains
    margins = loop_margins(form, lambda w: kp + kf * operator.response(w), spec.crossover)
    stable = closed_loop_stable(form, kp, kf, operator)
    margins = LoopMargins(**{**asdict(margins), "stable": stable})
    return Design(kind, kp, kf, operator, form, spec, margins, flat, rule)


def closed_loop_stable(form: LinearForm, kp: float, kf: float, operator: DiscreteOperator) -> bool:
    """Whether the loop closed by ``kp + kf D`` on the plant and its delay is stable.

    The closed loop's state matrix, from python-control's ``feedback`` of the state-space
    systems (every state of the controller, the plant and the delay kept), has all its
    eigenvalues strictly inside the unit circle.
    """
    import control

    controller = kp + kf * operator.to_control()
    plant = control.ss(form.plant())
    delay = control.ss(control.tf([1.0], [1.0] + [0.0] * form.computation_delay, dt=form.ts))
    closed = control.feedback(controller * plant, delay if form.computation_delay else 1)
    a = np.asarray(closed.A)
    return bool(a.size == 0 or np.max(np.abs(np.linalg.eigvals(a))) < 1.0 - 1e-12)


def design_pi(form: LinearForm, phase_margin: float = 50.0, crossover: float = 3.0) -> Design:
    r"""A PI with the Tustin integrator (the lab's) meeting the phase margin at the crossover.

    Parameters
    ----------
    form : LinearForm
        The plant and the loop's delay (:func:`~neckid.design.linear_form.linear_form`).
    phase_margin : float, default 50
        Degrees.
    crossover : float, default 3
        rad/s.

    Returns
    -------
    Design
        ``kf`` is :math:`k_i`.

    Raises
    ------
    ValueError
        If a PI cannot give that phase there (it adds between −90° and 0°; the message gives
        the plant's phase).

    Examples
    --------
    >>> import control
    >>> from neckid.design.linear_form import linear_form
    >>> form = linear_form(control.tf([0.14], [1, -1.9, 0.9], dt=0.02))  # 7/(s (0.2 s + 1))
    >>> design = design_pi(form, 50.0, 3.0)
    >>> round(design.margins.phase_margin, 3), round(design.margins.crossover, 3)
    (50.0, 3.0)
    """
    pm, wc = _checked_spec(phase_margin, crossover, form)
    operator = tustin_integrator(form.ts)
    kp, ki = solve_gains(form, complex(operator.response(wc)), pm, wc)
    if kp <= 0 or ki <= 0:
        phase = math.degrees(np.angle(form.response(wc)))
        raise ValueError(
            f"no PI gives a phase margin of {pm:g} deg at {wc:g} rad/s: the plant's phase there"
            f" is {phase:.1f} deg (with the loop's delay), so the controller must add"
            f" {-180 + pm - phase:.1f} deg, and a PI adds between -90 and 0 deg (got kp={kp:.4g},"
            f" ki={ki:.4g}); choose another crossover or margin, or a fractional controller"
        )
    spec = DesignSpec(pm, wc, False)
    return _finish("pi", (kp, ki), operator, form, spec, False, "a PI has no order")


def _operator_builder(
    discretisation: str,
    form: LinearForm,
    crossover: float,
    threshold: float,
    band: tuple[float, float] | None,
    sections: int,
) -> Callable[[float], DiscreteOperator]:
    if discretisation == "gl":
        return lambda alpha: grunwald_letnikov_operator(alpha, form.ts, threshold)
    if discretisation == "oustaloup":
        chosen = band if band is not None else default_band(crossover, form.ts)
        return lambda alpha: oustaloup_operator(alpha, form.ts, chosen, sections, crossover)
    raise ValueError(
        f"discretisation must be one of {', '.join(DISCRETISATIONS)}; got {discretisation!r}"
    )


class _IdealOperator:
    r""":math:`(j\\omega)^\\alpha` itself: the continuous operator the lab's tuner designs for."""

    def __init__(self, order: float) -> None:
        self.order = order

    def response(self, omega: ArrayLike) -> np.ndarray:
        return np.asarray((1j * np.asarray(omega, dtype=np.float64)) ** self.order)


def _slope_of(build: Callable[[float], Any], form: LinearForm, pm: float, wc: float) -> Any:
    """``alpha -> (kp, kf, total phase slope)`` for orders with positive gains, else None."""

    def evaluate(alpha: float) -> tuple[float, float, float] | None:
        operator = build(alpha)
        kp, kf = solve_gains(form, complex(operator.response(wc)), pm, wc)
        if kp <= 0 or kf <= 0:
            return None
        slope = phase_slope(lambda w: (kp + kf * operator.response(w)) * form.response(w), wc)
        return kp, kf, slope

    return evaluate


def _best_order(
    build: Callable[[float], Any], form: LinearForm, pm: float, wc: float
) -> tuple[float, bool]:
    """The order that flattens the phase (smallest Ms among roots), else the flattest one."""
    from scipy.optimize import brentq, minimize_scalar

    evaluate = _slope_of(build, form, pm, wc)
    table = {float(a): evaluate(float(a)) for a in _ORDERS}
    feasible = [a for a, v in table.items() if v is not None]
    if not feasible:
        raise ValueError(
            f"no fractional order in (-1, 1) gives positive gains for a phase margin of {pm:g}"
            f" deg at {wc:g} rad/s on this plant; choose another crossover or margin"
        )

    def slope(alpha: float) -> float:
        value = evaluate(alpha)
        return math.inf if value is None else value[2]

    roots = []
    for left, right in itertools.pairwise(_ORDERS):
        a, b = table[float(left)], table[float(right)]
        if a is not None and b is not None and a[2] * b[2] <= 0 and left * right > 0:
            root = brentq(slope, float(left), float(right), xtol=1e-10)
            if abs(slope(root)) < FLAT_TOLERANCE:
                roots.append(root)
    if roots:

        def peak(alpha: float) -> float:
            kp, kf, _ = evaluate(alpha)
            operator = build(alpha)
            return loop_margins(form, lambda w: kp + kf * operator.response(w), wc).sensitivity_peak

        return min(roots, key=peak), True
    best = min(feasible, key=lambda a: abs(table[a][2]))
    side = math.copysign(1.0, best)
    low, high = sorted((side * max(abs(best) - 0.01, 1e-3), side * min(abs(best) + 0.01, 0.999)))
    refined = minimize_scalar(lambda a: abs(slope(a)), bounds=(low, high), method="bounded")
    alpha = float(refined.x) if abs(slope(float(refined.x))) < abs(slope(best)) else best
    return alpha, False


def design_fractional(
    form: LinearForm,
    phase_margin: float = 50.0,
    crossover: float = 3.0,
    *,
    discretisation: Literal["gl", "oustaloup"] = "gl",
    order: float | None = None,
    threshold: float = GL_THRESHOLD,
    band: tuple[float, float] | None = None,
    sections: int = 5,
) -> Design:
    r"""A fractional :math:`k_p + k_f s^\alpha` meeting the margin at the crossover with a flat phase.

    Parameters
    ----------
    form : LinearForm
        The plant and the loop's delay.
    phase_margin : float, default 50
        Degrees.
    crossover : float, default 3
        rad/s.
    discretisation : {"gl", "oustaloup"}, default "gl"
        How :math:`s^\alpha` is realised (:mod:`neckid.design.operators`): the lab's truncated
        Grünwald–Letnikov sum, or Oustaloup's filter.
    order : float, optional
        Fix :math:`\alpha` (in (−1, 0) or (0, 1)) instead of choosing it for a flat phase.
    threshold : float, default 0.01
        ``"gl"``: the taps' truncation.
    band : (float, float), optional
        ``"oustaloup"``: the band, rad/s (default :math:`[\omega_c/100, \min(100\omega_c,
        \pi/(2T))]`).
    sections : int, default 5
        ``"oustaloup"``: :math:`n` (:math:`2n + 1` sections).

    Returns
    -------
    Design
        Margin and crossover met exactly on ``form`` by the realised controller; ``flat`` says
        whether the phase slope there is below 0.01 deg per rad/s. With ``"oustaloup"`` the
        order flattens the realised loop's phase; with ``"gl"`` it flattens the phase of the
        continuous :math:`s^\alpha` (the lab's choice), because the truncated sum's phase is not
        :math:`\alpha\pi/2` and jumps whenever its number of taps changes.

    Raises
    ------
    ValueError
        If no order gives positive gains, or a bad argument.

    Examples
    --------
    >>> import control
    >>> from neckid.design.linear_form import linear_form
    >>> plant = control.c2d(control.tf([7.0], [0.05, 1.0, 0.0]), 0.02, "zoh")
    >>> design = design_fractional(linear_form(plant), 50.0, 3.0, discretisation="oustaloup")
    >>> round(design.margins.phase_margin, 2), round(design.margins.crossover, 3), design.flat
    (50.0, 3.0, True)
    >>> round(design.order, 3)
    -0.747
    """
    pm, wc = _checked_spec(phase_margin, crossover, form)
    build = _operator_builder(discretisation, form, wc, threshold, band, sections)
    if order is not None:
        alpha, rule = check_number(order, "order"), "fixed"
    elif discretisation == "gl":
        # The truncated sum's phase is not alpha*pi/2 and jumps with its tap count: the order
        # comes from the ideal operator, as the lab's tuner takes it; the gains are exact below.
        alpha, ideal_flat = _best_order(_IdealOperator, form, pm, wc)
        rule = "ideal s^alpha flat" if ideal_flat else "ideal s^alpha flattest"
    else:
        alpha, realised_flat = _best_order(build, form, pm, wc)
        rule = "realised loop flat" if realised_flat else "realised loop flattest"
    operator = build(alpha)
    kp, kf = solve_gains(form, complex(operator.response(wc)), pm, wc)
    if kp <= 0 or kf <= 0:
        raise ValueError(
            f"the order {alpha:.4g} gives kp={kp:.4g}, kf={kf:.4g} for a phase margin of {pm:g}"
            f" deg at {wc:g} rad/s on this plant; a controller needs both positive: choose"
            " another order, crossover or margin"
        )
    slope = phase_slope(lambda w: (kp + kf * operator.response(w)) * form.response(w), wc)
    flat = abs(slope) < FLAT_TOLERANCE
    return _finish("fractional", (kp, kf), operator, form, DesignSpec(pm, wc, True), flat, rule)


def ideal_iso_damping(
    form: LinearForm, phase_margin: float = 50.0, crossover: float = 3.0
) -> tuple[float, float, float, bool]:
    r"""The iso-damping design for the continuous :math:`s^\alpha` (the problem the lab's tuner solves).

    The same three conditions with :math:`D(j\omega) = (j\omega)^\alpha` exactly (Monje et al.
    2008's closed forms), no realisation: what the lab's tuner computes before its controller
    realises :math:`s^\alpha` with the step-1 sum.

    Parameters
    ----------
    form : LinearForm
    phase_margin : float, default 50
        Degrees.
    crossover : float, default 3
        rad/s.

    Returns
    -------
    kp, kf, order : float
        :math:`k_f` is the lab tuner's :math:`k_d = \tau_a k` (the gain of :math:`s^\alpha`).
    flat : bool
    """
    pm, wc = _checked_spec(phase_margin, crossover, form)
    alpha, flat = _best_order(_IdealOperator, form, pm, wc)
    kp, kf = solve_gains(form, complex(_IdealOperator(alpha).response(wc)), pm, wc)
    return kp, kf, alpha, flat
