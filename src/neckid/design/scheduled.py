r"""Gain scheduling over the inclination from the scheduled model :math:`N(i)/(z - P(i))`.

The scheduled CFF-RLS model (:class:`~neckid.GainScheduledModel`) is a linear plant at every
inclination :math:`i`. :func:`design_scheduled` designs at each inclination of a grid (by default
the model's operating points) and interpolates the gains between them:

- a PI: :math:`(k_p, k_i)` at each inclination (:func:`~neckid.design.loop_shaping.design_pi`);
- a fractional controller: its order :math:`\alpha` is chosen once, at the middle of the grid
  (:func:`~neckid.design.loop_shaping.design_fractional`), and kept (one operator, one state: the
  lab's adaptive controller likewise keeps its order and retunes :math:`k_p, k_d` only); the
  gains at each inclination then meet the phase margin at the crossover exactly for that order.

The controller takes its gains at the *measured* inclination (linear interpolation, held at the
ends), the model's own scheduling variable.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from neckid.design.controllers import DesignedController, GainSchedule
from neckid.design.linear_form import linear_form
from neckid.design.loop_shaping import Design, design_fractional, design_pi
from neckid.utils.checks import check_vector
from neckid.utils.types import FloatArray

__all__ = ["ScheduledDesign", "design_scheduled"]


@dataclass(frozen=True)
class ScheduledDesign:
    """One design per inclination of the schedule.

    Attributes
    ----------
    inclinations : ndarray, shape (n,)
        deg, increasing.
    designs : tuple of Design
        One per inclination.
    """

    inclinations: FloatArray
    designs: tuple[Design, ...]

    @property
    def kind(self) -> str:
        """``"pi"`` or ``"fractional"``."""
        return self.designs[0].kind

    def schedule(self) -> GainSchedule:
        """The gains against the inclination."""
        return GainSchedule(
            self.inclinations,
            np.array([d.kp for d in self.designs]),
            np.array([d.kf for d in self.designs]),
        )

    def controller(
        self, *, command_limit: float | None = None, model: dict[str, Any] | None = None
    ) -> DesignedController:
        """The scheduled controller (the middle design's operator and its gains' table).

        Parameters
        ----------
        command_limit : float, optional
            Saturation of the command, rad/s.
        model : dict, optional
            What the model was, for the controller file.

        Returns
        -------
        DesignedController
        """
        middle = self.designs[len(self.designs) // 2]
        info: dict[str, Any] = {
            **middle.summary(),
            "schedule_designs": [
                {"inclination_deg": float(i), **d.summary()}
                for i, d in zip(self.inclinations, self.designs, strict=True)
            ],
            "plant": middle.form.to_dict(),
        }
        if model is not None:
            info["model"] = model
        return DesignedController(
            middle.kp,
            middle.kf,
            middle.operator,
            command_limit=command_limit,
            schedule=self.schedule(),
            info=info,
        )


def default_inclinations(model: Any) -> FloatArray:
    """The model's operating points [deg], rounded to 0.1 deg and sorted (two or more)."""
    points: FloatArray = np.unique(np.round(np.asarray(model.inclinations_, dtype=np.float64), 1))
    if points.size < 2:
        low, high = (float(v) for v in model.schedule_range_)
        points = np.linspace(low, high, 5) if high > low else np.array([low, low + 1.0])
    return np.asarray(points, dtype=np.float64)


def _at(inclination: float, make: Any, form: Any) -> Design:
    """``make(form)``, its error prefixed with the inclination."""
    try:
        design: Design = make(form)
    except ValueError as exc:
        raise ValueError(f"at {inclination:g} deg: {exc}") from None
    return design


def design_scheduled(
    model: Any,
    phase_margin: float = 50.0,
    crossover: float = 3.0,
    *,
    kind: Literal["pi", "fractional"] = "fractional",
    inclinations: ArrayLike | None = None,
    computation_delay: int = 1,
    drive_time_constant: float = 0.0,
    **fractional: Any,
) -> ScheduledDesign:
    """A controller scheduled over the inclination from a :class:`~neckid.GainScheduledModel`.

    Parameters
    ----------
    model : GainScheduledModel
        Fitted.
    phase_margin : float, default 50
        Degrees, at every inclination.
    crossover : float, default 3
        rad/s, at every inclination.
    kind : {"pi", "fractional"}, default "fractional"
    inclinations : array_like, optional
        The grid [deg], increasing (default: the model's operating points).
    computation_delay : int, default 1
        As :func:`~neckid.design.linear_form.linear_form`.
    drive_time_constant : float, default 0
        As :func:`~neckid.design.linear_form.linear_form` (a position-form model only).
    **fractional
        Passed to :func:`~neckid.design.loop_shaping.design_fractional` (``discretisation``,
        ``order``, ``threshold``, ``band``, ``sections``).

    Returns
    -------
    ScheduledDesign

    Raises
    ------
    TypeError
        If ``model`` is not a :class:`~neckid.GainScheduledModel`.
    ValueError
        If the grid has fewer than two increasing inclinations, or a design fails at one of
        them (the message names it).
    """
    from neckid.models.base import check_is_fitted
    from neckid.models.scheduled.model import GainScheduledModel

    if not isinstance(model, GainScheduledModel):
        raise TypeError(
            "a scheduled design needs a GainScheduledModel (the scheduled CFF-RLS model); got"
            f" {type(model).__name__}: design a fixed controller on it instead"
        )
    check_is_fitted(model)
    grid = (
        default_inclinations(model)
        if inclinations is None
        else check_vector(inclinations, "inclinations")
    )
    if grid.size < 2 or np.any(np.diff(grid) <= 0):
        raise ValueError(f"inclinations must be two or more increasing values; got {grid.tolist()}")
    forms = [
        linear_form(
            model,
            inclination=float(i),
            computation_delay=computation_delay,
            drive_time_constant=drive_time_constant,
        )
        for i in grid
    ]
    if kind not in ("pi", "fractional"):
        raise ValueError(f"kind must be 'pi' or 'fractional'; got {kind!r}")
    middle = len(forms) // 2
    designs: list[Design] = []
    anchor = None
    if kind == "fractional":
        # The order is chosen once, at the middle of the grid, and kept at every inclination.
        anchor = _at(
            grid[middle],
            lambda f: design_fractional(f, phase_margin, crossover, **fractional),
            forms[middle],
        )
        fractional = {**fractional, "order": anchor.order}
    for index, (i, form) in enumerate(zip(grid, forms, strict=True)):
        if anchor is not None and index == middle:
            designs.append(anchor)
        elif kind == "pi":
            designs.append(_at(i, lambda f: design_pi(f, phase_margin, crossover), form))
        else:
            designs.append(
                _at(i, lambda f: design_fractional(f, phase_margin, crossover, **fractional), form)
            )
    return ScheduledDesign(np.asarray(grid, dtype=np.float64), tuple(designs))
