"""What a closed-loop experiment needs from a plant and from a controller.

Structural types (:class:`typing.Protocol`): any object with the two methods fits, with no base
class to inherit. The simulated neck (:class:`~neckid.plant.SoftNeck`), an identified model's
``simulator()`` and a real rig's driver are plants; :class:`~neckid.plant.InclinationController`
is a controller. :func:`~neckid.plant.closed_loop` and
:func:`~neckid.loops.operating_points.identify_operating_points` take them.
"""

from __future__ import annotations

from typing import Protocol

from numpy.typing import ArrayLike

__all__ = ["BoundedSimulator", "Controller", "Plant", "Simulator"]


class Plant(Protocol):
    """A discrete-time plant: ``reset()``, then ``step(u) -> y`` once per sample.

    ``step`` applies the command of sample ``k`` and returns the output of sample ``k``, which
    must not depend on that command (no direct feedthrough), so that a loop can compute the next
    command from it.

    Examples
    --------
    >>> import numpy as np
    >>> class Integrator:
    ...     def reset(self):
    ...         self.y = 0.0
    ...     def step(self, u):
    ...         y, self.y = self.y, self.y + float(np.ravel(u)[0])
    ...         return np.array([y])
    >>> def first_outputs(plant: Plant, n: int) -> list[float]:
    ...     plant.reset()
    ...     return [float(plant.step([1.0])[0]) for _ in range(n)]
    >>> first_outputs(Integrator(), 3)
    [0.0, 1.0, 2.0]
    """

    def reset(self) -> object:  # pragma: no cover - protocol
        """Go back to the initial state."""

    def step(self, u: ArrayLike) -> ArrayLike:  # pragma: no cover - protocol
        """Apply the input ``u`` (shape ``(n_inputs,)``) for one sample; return this sample's output."""


class Controller(Protocol):
    """A discrete-time controller: ``reset()``, then ``step(reference, measurement) -> command``.

    For the neck, ``reference`` and ``measurement`` are the inclination in degrees (or
    inclination and orientation with three tendons) and the command is the motor velocity in
    rad/s, one value per motor.
    """

    def reset(self) -> object:  # pragma: no cover - protocol
        """Clear the controller's state (integrals, filters)."""

    def step(self, reference: ArrayLike, measurement: ArrayLike) -> ArrayLike:  # pragma: no cover
        """One control period: the command(s) from the reference and the last measurement."""


class Simulator(Protocol):
    """An identified model's step-by-step free run (``model.simulator()``): a plant with a history.

    ``reset(y0, u0)`` sets the past outputs and inputs (rows oldest first, one row repeated;
    default zeros); ``step(u)`` takes the input of sample ``t`` and returns the model output of
    sample ``t``. After ``reset(y0=y[:m], u0=u[:m])`` (``m`` the model's ``max_lag_``), stepping
    ``u[m:]`` gives what ``model.simulate`` gives. With no arguments ``reset()`` starts from
    rest, so a simulator is a :class:`Plant` and runs in :func:`~neckid.plant.closed_loop`.

    Notes
    -----
    A model with an input lag of 0 has direct feedthrough: ``step(u)`` returns an output that
    depends on ``u``, which a :class:`Plant` should not. :func:`~neckid.plant.closed_loop` still
    runs it as intended, because it computes the command of sample ``k`` from the output of
    sample ``k - 1``; the model then answers the command within the sample.
    """

    def reset(self, y0: ArrayLike | None = None, u0: ArrayLike | None = None) -> object:
        """Start again from the given (or zero) past outputs and inputs."""  # pragma: no cover

    def step(self, u: ArrayLike) -> ArrayLike:  # pragma: no cover - protocol
        """Advance one sample with input ``u`` (shape ``(n_inputs,)``); return ``y(t)``."""


class BoundedSimulator(Simulator, Protocol):
    """A :class:`Simulator` that also gives each step's band (the Set Membership models).

    ``step_bounds(u)`` advances like ``step`` and returns ``(y, lower, upper)``, each of shape
    ``(n_outputs,)``; :func:`neckid.loops.model_in_loop.model_in_the_loop` carries the band
    along a closed loop.
    """

    def step_bounds(self, u: ArrayLike) -> tuple[ArrayLike, ArrayLike, ArrayLike]:
        """Advance one sample; return the central output and the band."""  # pragma: no cover
