r"""The simulated soft neck: a tendon-driven soft link with a tilt sensor on its top platform.

The model (one bending vector :math:`b`, its rate, a Bouc–Wen hysteretic variable :math:`z`, and
one motor per tendon):

* **Motors** (Maxon RE16 + 24:1 gear in velocity mode): a first-order velocity loop
  :math:`\dot w = \mathrm{clip}((\mathrm{clip}(u, \pm w_{max}) - w)/\tau_m, \pm a_{max})`,
  :math:`\dot q = w` (gearbox output, rad).
* **Link kinematics**: constant curvature. A link of length :math:`L` bent by the angle
  :math:`\theta = |b|` towards the direction :math:`\varphi` carries the top platform at the
  bending angle :math:`\theta`, which is what the tilt sensor reads as *inclination*
  (:math:`\varphi` is the *orientation*). A straight tendon anchored at radius :math:`r` and
  angle :math:`\alpha_i` on base and platform has the length

  .. math:: l_i(b) = \frac{2\sin(\theta/2)}{\theta}\,\bigl(L - r\,e_i\cdot b\bigr),
     \qquad e_i = (\cos\alpha_i, \sin\alpha_i),

  (the chord of the arc of radius :math:`L/\theta - r\cos(\alpha_i - \varphi)`), so
  :math:`\partial l_i/\partial\theta = -r` at rest: 0.0075/0.052 rad of bending per rad of winch,
  8.3°/rad before any compliance.
* **Tendons pull only**: the stretch is the length wound on the winch minus the geometric
  shortening, :math:`s_i = r_w q_i - (L - l_i(b))`; the force is
  :math:`F_i = \max(0, k_t s_i + c_t \dot s_i)` when :math:`s_i > 0` and zero when the tendon is
  slack. :math:`k_t` lumps the tendon, its routing and the axial compression of the soft link.
* **Link dynamics** (generalised forces on :math:`b`, from virtual work):

  .. math:: J\ddot b = -K_0(1 + \beta\theta)\,b - H_0(1 + 2\beta\theta)\,z
     - c_0(1 + c_1\theta)\,\dot b + g\textstyle\sum_j m_j\bigl(L\,A(\theta) + h_j\,
     \frac{\sin\theta}{\theta}\bigr)\,b - \sum_i F_i\,\nabla_b l_i

  with :math:`A(\theta) = (\sin\theta - \theta\cos\theta)/\theta^3` (gravity of the head and
  the payload, centres of mass :math:`h_j` above the platform), a stiffness that grows with the
  bending (tangent :math:`K_0(1 + 2\beta\theta)`) and a damping that grows with it (tendon
  friction grows with the tension that holds a larger bending).
* **Hysteresis**: Bouc–Wen [1]_ [2]_ with :math:`n = 1`, :math:`A = 1`, per component,
  :math:`\dot z = \dot b\,(1 - (\beta_{bw}\,\mathrm{sgn}(\dot b z) + \gamma_{bw})|z|)`, whose
  :math:`|z|` saturates at the yield bending :math:`z_y = 1/(\beta_{bw} + \gamma_{bw})`.
* **Sensor**: the bending of ``sensor_delay`` seconds ago, plus white Gaussian noise per
  component (degrees), then its magnitude (inclination ≥ 0) and direction (orientation in
  [0, 360)), quantised to ``sensor_resolution``.

Integration: classical Runge–Kutta 4 with a fixed sub-step (``integration_step`` or less,
a whole number per sample), the command held over the sample (zero-order hold).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

import neckid.plant._kernels as _kernels
from neckid.data.iodata import IOData
from neckid.utils.checks import check_finite, check_ts
from neckid.utils.types import FloatArray

__all__ = ["Configuration", "SoftNeck", "SoftNeckParameters"]

Configuration = Literal["planar", "three_tendon"]

STANDARD_GRAVITY = 9.80665  # m/s^2

#: The error of a run whose state stopped being finite.
DIVERGED_MESSAGE = (
    "the simulation diverged (non-finite state); lower SoftNeckParameters.integration_step or"
    " check the parameters"
)


@dataclass(frozen=True)
class SoftNeckParameters:
    r"""Every physical parameter of :class:`SoftNeck` (SI units unless the name says degrees).

    Geometry and drive are facts of the UC3M HUMASoft bench [1]_ [2]_; the elastic, damping and
    hysteresis values are calibrated on the public logs of the same bench (see
    ``docs/simulator.md``): about 7° of inclination per rad of motor between 15° and 30°, the
    return slower than the rise, 0.02–0.03 rad of motor position between going up and coming down.

    Parameters
    ----------
    link_length : float, default 0.1085
        Length of the soft link between base and platform, m (bench drawings, HUMASoft neck).
    anchor_radius : float, default 0.052
        Radius of the tendon anchors on base and platform, m (bench drawings).
    winch_radius : float, default 0.0075
        Radius of the winch on the gearbox output, m (bench drawings).
    head_mass : float, default 0.15
        Mass of the top platform with the tilt sensor, kg. Estimate (3D-printed disc plus IMU
        board); it only sets the inertia and a small part of the gravity moment.
    head_height : float, default 0.02
        Height of the head's centre of mass above the platform centre, m (estimate).
    payload : float, default 0.0
        Mass on the head, kg, in [0, 1] (the logs use 0, 0.2, 0.4, 0.6 kg; the bench takes 1 kg).
    payload_height : float, default 0.03
        Height of the payload's centre of mass above the platform centre, m (estimate).
    bending_stiffness : float, default 1.2
        Bending stiffness of the soft link at rest, :math:`K_0`, N m/rad. Calibrated: with
        ``tendon_stiffness`` it sets the static map (7°/rad) and with ``bending_damping`` the
        return time (about 0.15 s time constant at small bending, as in the step logs).
    stiffening : float, default 1.5
        Growth of the stiffness with the bending, :math:`\beta`, 1/rad: the moment is
        :math:`K_0(1 + \beta\theta)\theta`, so the tangent stiffness at 35° is 2.8 times the one at
        rest. Calibrated on the fall of the static gain and of the paper's first-order gain with
        inclination.
    bending_damping : float, default 0.2
        Damping at rest, :math:`c_0`, N m s/rad (calibrated: return time constant).
    damping_growth : float, default 6.0
        Growth of the damping with the bending, :math:`c_1`, 1/rad: friction of the tendon in its
        guides grows with the tension, which grows with the bending. Calibrated on the rise of the
        paper's first-order pole with inclination.
    hysteresis_stiffness : float, default 1.6
        Stiffness of the Bouc–Wen element at rest, :math:`H_0`, N m/rad (scaled like the tangent
        stiffness, :math:`H_0(1 + 2\beta\theta)`). With ``hysteresis_yield`` it sets the
        hysteretic moment: :math:`H_0 z_y` = 0.016 N m at rest, about 0.013 rad of motor between
        going up and coming down on a closed-loop staircase, and a residual bending of about 0.7°
        after a release (the real neck starts its logs at 0.1–0.7°).
    hysteresis_yield : float, default 0.01
        Yield bending of the Bouc–Wen element, :math:`z_y = 1/(\beta_{bw} + \gamma_{bw})`, rad.
    hysteresis_shape : float, default 0.5
        :math:`\beta_{bw} / (\beta_{bw} + \gamma_{bw})` in [0, 1]: 0.5 gives the usual symmetric
        loop with a softening branch (Wen 1976).
    tendon_stiffness : float, default 5500.0
        Series stiffness of a tendon, N/m: the tendon, its routing to the winch and the axial
        compression of the soft link, lumped. Calibrated on the static map: the geometry alone
        gives 8.3°/rad, the real neck 7°/rad.
    tendon_damping : float, default 20.0
        Damping of a taut tendon, N s/m (small; it smooths the slack/taut transitions).
    motor_time_constant : float, default 0.015
        Time constant of the drive's velocity loop, s. In the logs the measured velocity follows
        the command within one 0.025 s sample.
    tendon_speed_limit : float, default 0.03
        Tendon speed limit, m/s (bench); the motor speed limit is
        ``tendon_speed_limit / winch_radius`` = 4 rad/s at the gearbox output, the commands are
        clipped to it.
    motor_acceleration_limit : float, default 200.0
        Acceleration limit of the drive (torque saturation), rad/s² at the gearbox output.
        Estimate: RE16 stall torque through 24:1 with the winch and link inertia.
    tendon_force_limit : float, default 40.0
        Largest tendon force the drive can wind against, N: beyond it the motor stalls (winds no
        further; it can still unwind). Estimate: RE16 stall torque (about 12 mN m) through 24:1 at
        about 80 % efficiency on a 0.0075 m winch gives 30–40 N. It also keeps an open-loop run
        bounded (about 60° at most) whatever the commands.
    sensor_noise : float, default 0.03
        Standard deviation of the tilt sensor's white noise, degrees, per component.
    sensor_resolution : float, default 0.01
        Quantisation of the tilt sensor, degrees (the raw IMU inclination in the logs).
    sensor_delay : float, default 0.04
        Delay of the tilt sensor (IMU filter and serial link), s: two samples at 0.02 s. Rounded to
        whole samples of the simulation's ``ts``.
    integration_step : float, default 0.0025
        Longest Runge–Kutta sub-step, s (eight per 0.02 s sample). A shorter one is used when
        :meth:`fastest_rate` asks for it (stiff damping or tendons), so any valid parameter set
        integrates stably.

    Raises
    ------
    ValueError
        If a parameter is not finite or is outside its range; the message names it and its value.

    References
    ----------
    .. [1] J. Muñoz, F. Quevedo, C. A. Monje, C. Balaguer et al., soft neck of the humanoid TEO,
       HUMASoft project (UC3M Robotics Lab); bench code github.com/munozyanez/phd_Archived.
    .. [2] L. Nagua, J. Muñoz, C. A. Monje, C. Balaguer, "A first approach to a proposal of a soft
       robotic link acting as a neck", XXXIX Jornadas de Automática, 2018.

    Examples
    --------
    >>> from neckid.plant import SoftNeckParameters
    >>> p = SoftNeckParameters(payload=0.6)
    >>> round(p.motor_speed_limit, 3)
    4.0
    >>> SoftNeckParameters(payload=-1.0)
    Traceback (most recent call last):
    ...
    ValueError: payload must be in [0, 1] kg; got -1.0
    """

    link_length: float = 0.1085
    anchor_radius: float = 0.052
    winch_radius: float = 0.0075
    head_mass: float = 0.15
    head_height: float = 0.02
    payload: float = 0.0
    payload_height: float = 0.03
    bending_stiffness: float = 1.2
    stiffening: float = 1.5
    bending_damping: float = 0.2
    damping_growth: float = 6.0
    hysteresis_stiffness: float = 1.6
    hysteresis_yield: float = 0.01
    hysteresis_shape: float = 0.5
    tendon_stiffness: float = 5500.0
    tendon_damping: float = 20.0
    motor_time_constant: float = 0.015
    tendon_speed_limit: float = 0.03
    motor_acceleration_limit: float = 200.0
    tendon_force_limit: float = 40.0
    sensor_noise: float = 0.03
    sensor_resolution: float = 0.01
    sensor_delay: float = 0.04
    integration_step: float = 0.0025

    def __post_init__(self) -> None:
        positive = (
            ("link_length", "m"),
            ("anchor_radius", "m"),
            ("winch_radius", "m"),
            ("head_mass", "kg"),
            ("bending_stiffness", "N m/rad"),
            ("bending_damping", "N m s/rad"),
            ("hysteresis_yield", "rad"),
            ("tendon_stiffness", "N/m"),
            ("motor_time_constant", "s"),
            ("tendon_speed_limit", "m/s"),
            ("motor_acceleration_limit", "rad/s^2"),
            ("tendon_force_limit", "N"),
            ("sensor_resolution", "deg"),
            ("integration_step", "s"),
        )
        non_negative = (
            ("head_height", "m"),
            ("payload_height", "m"),
            ("stiffening", "1/rad"),
            ("damping_growth", "1/rad"),
            ("hysteresis_stiffness", "N m/rad"),
            ("tendon_damping", "N s/m"),
            ("sensor_noise", "deg"),
            ("sensor_delay", "s"),
        )
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise TypeError(f"{f.name} must be a number; got {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"{f.name} must be finite; got {value!r}")
        for name, unit in positive:
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0 {unit}; got {getattr(self, name)!r}")
        for name, unit in non_negative:
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0 {unit}; got {getattr(self, name)!r}")
        if not 0.0 <= self.payload <= 1.0:
            raise ValueError(f"payload must be in [0, 1] kg; got {self.payload!r}")
        if not 0.0 <= self.hysteresis_shape <= 1.0:
            raise ValueError(f"hysteresis_shape must be in [0, 1]; got {self.hysteresis_shape!r}")
        if self.anchor_radius >= self.link_length:
            raise ValueError(
                f"anchor_radius must be smaller than link_length ({self.link_length!r} m);"
                f" got {self.anchor_radius!r}"
            )
        # Upright must be stable without tendon force: stiffness beats gravity's pull at rest.
        gravity = STANDARD_GRAVITY * (
            (self.head_mass + self.payload) * self.link_length / 3.0
            + self.head_mass * self.head_height
            + self.payload * self.payload_height
        )
        if self.bending_stiffness <= gravity:
            raise ValueError(
                f"bending_stiffness must exceed the gravity moment per radian at rest"
                f" ({gravity:.3g} N m/rad with this head and payload) or the neck falls over;"
                f" got {self.bending_stiffness!r}"
            )

    @property
    def motor_speed_limit(self) -> float:
        """Speed limit at the gearbox output, rad/s: ``tendon_speed_limit / winch_radius``."""
        return self.tendon_speed_limit / self.winch_radius

    @property
    def inertia(self) -> float:
        r"""Moment of inertia about the bending, kg m²: :math:`\sum_j m_j (L/2 + h_j)^2`.

        A small-bending estimate: the platform centre moves :math:`L/2` per radian of bending at
        rest, and a mass :math:`h_j` above it another :math:`h_j`.
        """
        half = 0.5 * self.link_length
        return (
            self.head_mass * (half + self.head_height) ** 2
            + self.payload * (half + self.payload_height) ** 2
        )

    def packed(self) -> FloatArray:
        """The parameters as the kernel's vector (see ``neckid.plant._kernels``)."""
        k = _kernels
        p = np.zeros(k.N_PACKED)
        p[k.LINK_LENGTH] = self.link_length
        p[k.ANCHOR_RADIUS] = self.anchor_radius
        p[k.WINCH_RADIUS] = self.winch_radius
        p[k.INERTIA] = self.inertia
        p[k.GRAVITY_ARC] = STANDARD_GRAVITY * (self.head_mass + self.payload) * self.link_length
        p[k.GRAVITY_HEAD] = STANDARD_GRAVITY * (
            self.head_mass * self.head_height + self.payload * self.payload_height
        )
        p[k.STIFFNESS] = self.bending_stiffness
        p[k.STIFFENING] = self.stiffening
        p[k.DAMPING] = self.bending_damping
        p[k.DAMPING_GROWTH] = self.damping_growth
        p[k.HYSTERESIS_STIFFNESS] = self.hysteresis_stiffness
        p[k.BOUC_WEN_BETA] = self.hysteresis_shape / self.hysteresis_yield
        p[k.BOUC_WEN_GAMMA] = (1.0 - self.hysteresis_shape) / self.hysteresis_yield
        p[k.TENDON_STIFFNESS] = self.tendon_stiffness
        p[k.TENDON_DAMPING] = self.tendon_damping
        p[k.MOTOR_TIME_CONSTANT] = self.motor_time_constant
        p[k.MOTOR_SPEED_LIMIT] = self.motor_speed_limit
        p[k.MOTOR_ACCELERATION_LIMIT] = self.motor_acceleration_limit
        p[k.SENSOR_NOISE] = self.sensor_noise
        p[k.SENSOR_RESOLUTION] = self.sensor_resolution
        p[k.TENDON_FORCE_LIMIT] = self.tendon_force_limit
        return p

    def fastest_rate(self) -> float:
        r"""A bound on the fastest rate of the model, 1/s, over the 0–40° range.

        The largest of: the damping over the inertia, the undamped frequency of the link on a
        taut tendon, the Bouc–Wen rate at the top tendon speed, and the drive's bandwidth. The
        Runge–Kutta sub-step is chosen so that it times the sub-step stays below 1.5 (RK4 is
        stable on the negative real axis up to 2.78).
        """
        top = math.radians(40.0)
        inertia = self.inertia
        damping = self.bending_damping * (1.0 + self.damping_growth * top) / inertia
        stiffness = (self.bending_stiffness + self.hysteresis_stiffness) * (
            1.0 + 2.0 * self.stiffening * top
        ) + 3.0 * self.tendon_stiffness * self.anchor_radius**2
        spring = math.sqrt(stiffness / inertia) + self.tendon_damping * (
            3.0 * self.anchor_radius**2 / inertia
        )
        bending_speed = self.tendon_speed_limit / self.anchor_radius
        hysteresis = bending_speed / self.hysteresis_yield
        return max(damping, spring, hysteresis, 1.0 / self.motor_time_constant)

    def to_dict(self) -> dict[str, float]:
        """The parameters as a plain dict (for JSON metadata)."""
        return {k: float(v) for k, v in asdict(self).items()}


def _tendon_directions(configuration: str) -> FloatArray:
    if configuration == "planar":
        return np.ones((1, 1))
    angles = np.radians([0.0, 120.0, 240.0])
    return np.column_stack([np.cos(angles), np.sin(angles)])


class SoftNeck:
    """The simulated soft neck: velocity commands in, tilt-sensor inclination (and orientation) out.

    Parameters
    ----------
    parameters : SoftNeckParameters, optional
        The physical parameters; default ``SoftNeckParameters()`` (no payload).
    configuration : {"planar", "three_tendon"}, default "planar"
        ``"planar"``: one tendon, the neck bends in one plane, output the inclination.
        ``"three_tendon"``: three tendons at 0°, 120° and 240°, outputs inclination and orientation
        (the direction the neck leans to, 0° towards tendon 1, counter-clockwise).
    ts : float, default 0.02
        Sampling (control) period, s.
    seed : int, optional
        Seed of the sensor noise (``numpy.random.default_rng``); every ``reset`` restarts it, so a
        neck gives the same log for the same commands every time. Default 0.

    Attributes
    ----------
    n_motors : int
        1 (planar) or 3 (three tendons).
    n_outputs : int
        1 (inclination) or 2 (inclination, orientation).
    input_names, output_names : tuple of str
        The channel names of :meth:`run`'s log.

    Notes
    -----
    The equations are in the module docstring (:mod:`neckid.plant.soft_neck`). Timing: the
    measurement of sample ``k`` is taken at the start of the sample, before the command of sample
    ``k`` acts, so it never depends on it (the log's ``y[k]`` goes with ``u[k]`` as in the real
    bench's logs, and as in :class:`neckid.models.base.NarxSimulator`).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid.plant import SoftNeck
    >>> neck = SoftNeck(seed=1)
    >>> data = neck.run(np.r_[np.full(50, 2.0), np.zeros(50)])   # wind 1 s at 2 rad/s, hold
    >>> data.input_names
    ('velocity_command', 'motor_position', 'motor_velocity')
    >>> bool(13.0 < data.y[-1, 0] < 16.0)                          # about 7 deg per rad
    True
    >>> neck.reset()
    >>> neck.step([2.0]).shape
    (1,)
    """

    def __init__(
        self,
        parameters: SoftNeckParameters | None = None,
        configuration: Configuration = "planar",
        ts: float = 0.02,
        seed: int | None = 0,
    ) -> None:
        if parameters is None:
            parameters = SoftNeckParameters()
        if not isinstance(parameters, SoftNeckParameters):
            raise TypeError(
                f"parameters must be a SoftNeckParameters; got {type(parameters).__name__}"
            )
        if configuration not in ("planar", "three_tendon"):
            raise ValueError(
                f"configuration must be 'planar' or 'three_tendon'; got {configuration!r}"
            )
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int | np.integer)):
            raise TypeError(f"seed must be an int or None; got {seed!r}")
        self.parameters = parameters
        self.configuration: Configuration = configuration
        self.seed = seed
        self._directions = _tendon_directions(configuration)
        self._packed = parameters.packed()
        self.n_motors = int(self._directions.shape[0])
        self._n_dof = int(self._directions.shape[1])
        self.n_outputs = 1 if configuration == "planar" else 2
        if configuration == "planar":
            self.input_names: tuple[str, ...] = (
                "velocity_command",
                "motor_position",
                "motor_velocity",
            )
            self.output_names: tuple[str, ...] = ("inclination",)
        else:
            self.input_names = tuple(
                f"{kind}_{i}"
                for kind in ("velocity_command", "motor_position", "motor_velocity")
                for i in range(1, 4)
            )
            self.output_names = ("inclination", "orientation")
        self.input_units = tuple(
            "rad" if n.startswith("motor_position") else "rad/s" for n in self.input_names
        )
        self.output_units = ("deg",) * self.n_outputs
        self._set_ts(ts)
        self.reset()

    # ------------------------------------------------------------------ set-up
    def _set_ts(self, ts: float) -> None:
        value = check_ts(ts)
        self.ts = value
        step = min(self.parameters.integration_step, 1.5 / self.parameters.fastest_rate())
        self._n_sub = max(1, math.ceil(value / step - 1e-9))
        self._dt = value / self._n_sub
        self._delay = round(self.parameters.sensor_delay / value)

    def reset(self) -> None:
        """Back to rest: upright, tendons just taut with no force, motors at 0, noise restarted."""
        n_state = 2 * self.n_motors + 3 * self._n_dof
        self._state = np.zeros(n_state)
        self._buffer = np.zeros((self._delay + 1, self._n_dof))
        self._head = np.zeros(1, dtype=np.int64)
        self._rng = np.random.default_rng(self.seed)

    # ------------------------------------------------------------------ state
    @property
    def delay_samples(self) -> int:
        """Sensor delay in whole samples of ``ts``."""
        return self._delay

    @property
    def motor_position(self) -> FloatArray:
        """Motor positions now, rad at the gearbox output, shape ``(n_motors,)``."""
        return self._state[: self.n_motors].copy()

    @property
    def motor_velocity(self) -> FloatArray:
        """Motor velocities now, rad/s at the gearbox output, shape ``(n_motors,)``."""
        return self._state[self.n_motors : 2 * self.n_motors].copy()

    @property
    def bending(self) -> FloatArray:
        """True bending vector now (no sensor), degrees, shape ``(1,)`` or ``(2,)`` (x, y)."""
        start = 2 * self.n_motors
        return np.degrees(self._state[start : start + self._n_dof])

    @property
    def inclination(self) -> float:
        """True inclination now (no sensor noise, delay nor quantisation), degrees."""
        return float(np.hypot.reduce(self.bending)) if self._n_dof > 1 else abs(self.bending[0])

    @property
    def tendon_force(self) -> FloatArray:
        """Tendon forces now, N, shape ``(n_motors,)``: zero for a slack tendon."""
        _, _, force = _kernels.tendon_state_reference(self._state, self._packed, self._directions)
        return force

    @property
    def tendon_stretch(self) -> FloatArray:
        """Wound length minus geometric shortening, m, shape ``(n_motors,)``: < 0 when slack."""
        stretch, _, _ = _kernels.tendon_state_reference(self._state, self._packed, self._directions)
        return stretch

    # ------------------------------------------------------------------ simulation
    def _commands(self, commands: ArrayLike, argument: str) -> FloatArray:
        try:
            array = np.asarray(commands, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{argument} must be numeric; got {commands!r:.80}") from exc
        if array.ndim == 1 and self.n_motors == 1:
            array = array[:, None]
        if array.ndim != 2 or array.shape[1] != self.n_motors:
            raise ValueError(
                f"{argument} must have shape (n_samples, {self.n_motors}) (one column per motor"
                f" of the {self.configuration} neck); got shape {array.shape}"
            )
        if array.shape[0] == 0:
            raise ValueError(f"{argument} must hold at least one sample; got 0 rows")
        names = self.input_names[: self.n_motors]
        check_finite(array, argument, names)
        return np.ascontiguousarray(array)

    def _advance(
        self, commands: FloatArray, noise: FloatArray, compiled: bool = True
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        n = commands.shape[0]
        outputs = np.empty((n, self.n_outputs))
        position = np.empty((n, self.n_motors))
        velocity = np.empty((n, self.n_motors))
        kernel = _kernels.simulate_compiled if compiled else _kernels.simulate_reference
        if not np.all(np.isfinite(self._state)):
            raise FloatingPointError("the neck's state is not finite; call reset()")
        kernel(
            self._state,
            self._buffer,
            self._head,
            commands,
            noise,
            self._packed,
            self._directions,
            self._n_sub,
            self._dt,
            outputs,
            position,
            velocity,
        )
        if not np.all(np.isfinite(self._state)):
            raise FloatingPointError(DIVERGED_MESSAGE)
        return outputs, position, velocity

    def step(self, u: ArrayLike) -> FloatArray:
        """Apply one sample of velocity command(s); return the measurement of this sample.

        Parameters
        ----------
        u : array_like, shape (n_motors,)
            Velocity command(s), rad/s at the gearbox output (a scalar for the planar neck).

        Returns
        -------
        ndarray, shape (n_outputs,)
            Inclination [deg] (and orientation [deg]) measured at the start of this sample, before
            ``u`` acts; the motors and link then move under ``u`` for ``ts`` seconds.

        Raises
        ------
        ValueError
            If ``u`` has the wrong number of values or holds NaN or inf.
        """
        command = np.asarray(u, dtype=np.float64).reshape(-1)
        if command.shape[0] != self.n_motors:
            raise ValueError(
                f"u must have {self.n_motors} value(s), one per motor of the {self.configuration}"
                f" neck; got {command.shape[0]}"
            )
        matrix = self._commands(command[None, :], "u")
        noise = self._rng.standard_normal((1, self._n_dof))
        outputs, _, _ = self._advance(matrix, noise)
        return outputs[0]

    def run(self, commands: ArrayLike, ts: float | None = None) -> IOData:
        """Reset the neck and run a whole sequence of velocity commands; return the log.

        Parameters
        ----------
        commands : array_like, shape (n_samples,) or (n_samples, n_motors)
            Velocity commands, rad/s at the gearbox output, one row per sample.
        ts : float, optional
            Sampling period, s; it becomes the neck's ``ts`` (for later ``step`` calls too).
            Default: the neck's ``ts``.

        Returns
        -------
        IOData
            Inputs ``velocity_command`` [rad/s], ``motor_position`` [rad], ``motor_velocity``
            [rad/s] (``_1`` .. ``_3`` for three tendons), outputs ``inclination`` [deg] (and
            ``orientation`` [deg]). Row ``k`` is measured at the start of sample ``k``. It is the
            same log as ``reset()`` followed by ``step`` on each row.

        Raises
        ------
        ValueError
            If the commands have the wrong number of columns or hold NaN or inf, or ``ts <= 0``.
        """
        matrix = self._commands(commands, "commands")
        if ts is not None:
            self._set_ts(ts)
        self.reset()
        noise = self._rng.standard_normal((matrix.shape[0], self._n_dof))
        outputs, position, velocity = self._advance(matrix, noise)
        return IOData(
            np.hstack([matrix, position, velocity]),
            outputs,
            self.ts,
            input_names=self.input_names,
            output_names=self.output_names,
            input_units=self.input_units,
            output_units=self.output_units,
            name=f"SoftNeck({self.configuration}, seed={self.seed})",
        )

    def __repr__(self) -> str:
        return (
            f"SoftNeck(configuration={self.configuration!r}, ts={self.ts!r}, seed={self.seed!r},"
            f" payload={self.parameters.payload!r})"
        )
