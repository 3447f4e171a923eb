"""Inner loop of the simulated soft neck: compiled kernels and the plain NumPy reference beside them.

:func:`simulate_compiled` and :func:`simulate_reference` advance the same state with the same
equations (documented in :mod:`neckid.plant.soft_neck`) and must agree to rounding;
``tests/test_plant.py`` checks it (the quantised sensor readings come out identical).
:func:`closed_loop_compiled` runs the PI inclination loop of :func:`neckid.plant.closed_loop`
around the same per-sample step (:func:`_sample`); its reference is that function's loop over
the Python objects, and the tests check that both give the same log bit for bit. The public
wrappers (:class:`neckid.plant.SoftNeck`, :func:`neckid.plant.closed_loop`) validate, cast to
contiguous ``float64`` and allocate; the kernels only loop.

State vector ``x`` (length ``2 m + 3 d``, ``m`` motors, ``d`` bending components: 1 planar,
2 three-tendon)::

    x[0:m]          motor positions q [rad, gearbox output]
    x[m:2m]         motor velocities w [rad/s]
    x[2m:2m+d]      bending vector b [rad] (planar: the bending angle theta)
    x[2m+d:2m+2d]   bending rate db/dt [rad/s]
    x[2m+2d:2m+3d]  Bouc-Wen hysteretic variable z [rad]
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from neckid.utils.types import FloatArray, IntArray

# Indices into the packed parameter vector (see SoftNeckParameters.packed).
LINK_LENGTH = 0
ANCHOR_RADIUS = 1
WINCH_RADIUS = 2
INERTIA = 3
GRAVITY_ARC = 4  # g * sum(m_j) * L          [N m]
GRAVITY_HEAD = 5  # g * sum(m_j * h_j)       [N m]
STIFFNESS = 6  # K0                           [N m/rad]
STIFFENING = 7  # beta                        [1/rad]
DAMPING = 8  # c0                             [N m s/rad]
DAMPING_GROWTH = 9  # c1                      [1/rad]
HYSTERESIS_STIFFNESS = 10  # H0               [N m/rad]
BOUC_WEN_BETA = 11  # [1/rad]
BOUC_WEN_GAMMA = 12  # [1/rad]
TENDON_STIFFNESS = 13  # [N/m]
TENDON_DAMPING = 14  # [N s/m]
MOTOR_TIME_CONSTANT = 15  # [s]
MOTOR_SPEED_LIMIT = 16  # [rad/s]
MOTOR_ACCELERATION_LIMIT = 17  # [rad/s^2]
SENSOR_NOISE = 18  # [deg]
SENSOR_RESOLUTION = 19  # [deg]
TENDON_FORCE_LIMIT = 20  # [N]
N_PACKED = 21

SMALL_ANGLE = 1e-2  # below this bending angle [rad] the NumPy reference uses short series
RAD2DEG = 180.0 / math.pi


# Taylor coefficients of the shape functions in t = theta^2 (all four are even in theta), 12 terms:
#   S(theta)     = 2 sin(theta/2) / theta      = sum_k (-1)^k t^k / (4^k (2k+1)!)
#   S'(theta)/th                               = sum_k (-1)^(k+1) 2(k+1) t^k / (4^(k+1) (2k+3)!)
#   A(theta)     = (sin - theta cos) / theta^3 = sum_k (-1)^k 2(k+1) t^k / (2k+3)!
#   sinc(theta)  = sin(theta) / theta          = sum_k (-1)^k t^k / (2k+1)!
# Below SERIES_LIMIT (theta < pi/2) the first omitted term is below 1e-20 of the sum, so the series
# are exact to rounding; above it the closed forms are used (see _shape_functions).
_N_TERMS = 12
S_SERIES = tuple((-1) ** k / (4**k * math.factorial(2 * k + 1)) for k in range(_N_TERMS))
S_PRIME_SERIES = tuple(
    (-1) ** (k + 1) * 2 * (k + 1) / (4 ** (k + 1) * math.factorial(2 * k + 3))
    for k in range(_N_TERMS)
)
A_SERIES = tuple((-1) ** k * 2 * (k + 1) / math.factorial(2 * k + 3) for k in range(_N_TERMS))
SINC_SERIES = tuple((-1) ** k / math.factorial(2 * k + 1) for k in range(_N_TERMS))
SERIES_LIMIT = (0.5 * math.pi) ** 2


# ---------------------------------------------------------------------------------------------
# compiled kernels
# ---------------------------------------------------------------------------------------------
#: Let LLVM fuse a multiply and an add into one FMA (rounded once: as accurate or more) in the
#: integration only; the sensor and the PI law keep plain IEEE arithmetic, so the compiled closed
#: loop computes its commands exactly as InclinationController does.
_CONTRACT = {"contract"}


# Speed notes (benchmarks/bench_plant.py): one sample is 4 * n_sub evaluations of _derivatives in
# a chain (each Runge-Kutta stage needs the previous one), so the kernel is bound by the latency
# of one evaluation, not by its operation count. What shortens that chain: the shape functions as
# polynomials in theta^2 by Estrin's scheme (no sqrt, sin or cos on the path), the bending
# components held in scalars (d <= 2), multiplications by reciprocals instead of divisions, fused
# multiply-adds, and _derivatives inlined into a single call site. error_model="numpy": a
# division by zero gives inf / nan (caught by the wrappers' finiteness checks) instead of a
# Python exception check on every division.
@njit(cache=True, error_model="numpy", fastmath=_CONTRACT)
def _series(t: float, c: tuple[float, ...]) -> float:  # pragma: no cover - compiled
    """sum_k c[k] t^k for 12 coefficients, by Estrin's scheme (short dependency chains)."""
    t2 = t * t
    t4 = t2 * t2
    low = (c[0] + c[1] * t) + t2 * (c[2] + c[3] * t)
    mid = (c[4] + c[5] * t) + t2 * (c[6] + c[7] * t)
    high = (c[8] + c[9] * t) + t2 * (c[10] + c[11] * t)
    return low + t4 * (mid + t4 * high)


@njit(cache=True, error_model="numpy", fastmath=_CONTRACT, inline="always")
def _shape_functions(
    theta: float, theta2: float
) -> tuple[float, float, float, float]:  # pragma: no cover
    """S = 2 sin(theta/2)/theta, S'/theta, A = (sin - theta cos)/theta^3, sinc = sin(theta)/theta."""
    if theta2 < SERIES_LIMIT:
        return (
            _series(theta2, S_SERIES),
            _series(theta2, S_PRIME_SERIES),
            _series(theta2, A_SERIES),
            _series(theta2, SINC_SERIES),
        )
    # the closed forms, through the half angle: sin = 2 sin(theta/2) cos(theta/2),
    # cos = 1 - 2 sin(theta/2)^2 (two calls to libm instead of four)
    half_sin = math.sin(0.5 * theta)
    half_cos = math.cos(0.5 * theta)
    inverse = 1.0 / theta
    s = 2.0 * half_sin * inverse
    sinc = 2.0 * half_sin * half_cos * inverse
    cos_t = 1.0 - 2.0 * half_sin * half_sin
    return s, (half_cos - s) * inverse * inverse, (sinc - cos_t) * inverse * inverse, sinc


@njit(cache=True, error_model="numpy", fastmath=_CONTRACT, inline="always")
def _derivatives(
    x: FloatArray,
    u: FloatArray,
    p: FloatArray,
    directions: FloatArray,
    m: int,
    d: int,
    dx: FloatArray,
    row: int,
) -> None:  # pragma: no cover - compiled; checked against _derivatives_reference
    """Time derivative of the state ``x`` into ``dx[row]`` (``d`` is 1 or 2)."""
    length = p[LINK_LENGTH]
    radius = p[ANCHOR_RADIUS]
    winch = p[WINCH_RADIUS]
    ib = 2 * m
    iv = ib + d
    iz = iv + d
    planar = d == 1
    # bending vector b, its rate v and the Bouc-Wen variable z (second components 0 when planar)
    b0, v0, z0 = x[ib], x[iv], x[iz]
    b1 = 0.0 if planar else x[ib + 1]
    v1 = 0.0 if planar else x[iv + 1]
    z1 = 0.0 if planar else x[iz + 1]
    theta2 = b0 * b0 + b1 * b1
    theta = math.sqrt(theta2)
    s, sp_over, a, sinc = _shape_functions(theta, theta2)
    # motors: first-order velocity loop with command saturation and acceleration limit; a drive
    # pulling with the force limit stalls (winds no further)
    w_max = p[MOTOR_SPEED_LIMIT]
    a_max = p[MOTOR_ACCELERATION_LIMIT]
    for i in range(m):
        dx[row, i] = x[m + i]
        dx[row, m + i] = min(max(u[i], -w_max), w_max)  # finished below, once the force is known
    # generalised forces on the bending vector
    stiff = p[STIFFNESS] * (1.0 + p[STIFFENING] * theta)
    tangent = p[HYSTERESIS_STIFFNESS] * (1.0 + 2.0 * p[STIFFENING] * theta)
    damp = p[DAMPING] * (1.0 + p[DAMPING_GROWTH] * theta)
    grav = p[GRAVITY_ARC] * a + p[GRAVITY_HEAD] * sinc
    moment0 = -stiff * b0 - tangent * z0 - damp * v0 + grav * b0
    moment1 = -stiff * b1 - tangent * z1 - damp * v1 + grav * b1
    s_radius = s * radius
    for i in range(m):
        e0 = directions[i, 0]
        e1 = 0.0 if planar else directions[i, 1]
        lever = length - radius * (e0 * b0 + e1 * b1)
        stretch = winch * x[i] - (length - s * lever)
        if stretch <= 0.0:
            continue
        # gradient of the tendon length with respect to b
        spl = sp_over * lever
        g0 = spl * b0 - s_radius * e0
        g1 = spl * b1 - s_radius * e1
        length_rate = g0 * v0 + g1 * v1
        force = p[TENDON_STIFFNESS] * stretch + p[TENDON_DAMPING] * (winch * x[m + i] + length_rate)
        if force <= 0.0:
            continue
        if force >= p[TENDON_FORCE_LIMIT] and dx[row, m + i] > 0.0:
            dx[row, m + i] = 0.0
        moment0 -= force * g0
        moment1 -= force * g1
    inverse_tau = 1.0 / p[MOTOR_TIME_CONSTANT]
    for i in range(m):
        acc = (dx[row, m + i] - x[m + i]) * inverse_tau
        dx[row, m + i] = min(max(acc, -a_max), a_max)
    inverse_inertia = 1.0 / p[INERTIA]
    beta = p[BOUC_WEN_BETA]
    gamma = p[BOUC_WEN_GAMMA]
    # Bouc-Wen (n = 1, A = 1): dz = db (1 - (beta sgn(db z) + gamma) |z|)
    dx[row, ib] = v0
    dx[row, iv] = moment0 * inverse_inertia
    sign = 1.0 if v0 * z0 > 0.0 else (-1.0 if v0 * z0 < 0.0 else 0.0)
    dx[row, iz] = v0 * (1.0 - (beta * sign + gamma) * abs(z0))
    if not planar:
        dx[row, ib + 1] = v1
        dx[row, iv + 1] = moment1 * inverse_inertia
        sign = 1.0 if v1 * z1 > 0.0 else (-1.0 if v1 * z1 < 0.0 else 0.0)
        dx[row, iz + 1] = v1 * (1.0 - (beta * sign + gamma) * abs(z1))


@njit(cache=True, error_model="numpy")
def _measure(
    bending: FloatArray, noise: FloatArray, p: FloatArray, d: int, out: FloatArray
) -> None:  # pragma: no cover - compiled; checked against the reference
    resolution = p[SENSOR_RESOLUTION]
    sigma = p[SENSOR_NOISE]
    if d == 1:
        value = abs(bending[0] * RAD2DEG + sigma * noise[0])
        out[0] = math.floor(value / resolution + 0.5) * resolution
    else:
        vx = bending[0] * RAD2DEG + sigma * noise[0]
        vy = bending[1] * RAD2DEG + sigma * noise[1]
        incl = math.sqrt(vx * vx + vy * vy)
        orient = math.atan2(vy, vx) * RAD2DEG
        if orient < 0.0:
            orient += 360.0
        out[0] = math.floor(incl / resolution + 0.5) * resolution
        orient = math.floor(orient / resolution + 0.5) * resolution
        if orient >= 360.0:
            orient -= 360.0
        out[1] = orient


@njit(cache=True, error_model="numpy", fastmath=_CONTRACT)
def _sample(
    state: FloatArray,
    buffer: FloatArray,
    head: IntArray,
    u: FloatArray,
    noise: FloatArray,
    p: FloatArray,
    directions: FloatArray,
    n_sub: int,
    dt: float,
    outputs: FloatArray,
    motor_position: FloatArray,
    motor_velocity: FloatArray,
    k: int,
    slopes: FloatArray,
    work: FloatArray,
) -> None:  # pragma: no cover - compiled; checked against simulate_reference
    """One sample: measure into ``outputs[k]``, log the motors, integrate ``n_sub`` RK4 steps."""
    m = directions.shape[0]
    d = directions.shape[1]
    nx = state.shape[0]
    ib = 2 * m
    h = head[0]
    for j in range(d):
        buffer[h, j] = state[ib + j]
    oldest = (h + 1) % buffer.shape[0]
    _measure(buffer[oldest], noise[k], p, d, outputs[k])
    head[0] = oldest
    for i in range(m):
        motor_position[k, i] = state[i]
        motor_velocity[k, i] = state[m + i]
    half = 0.5 * dt
    sixth = dt / 6.0
    for _ in range(n_sub):
        # classical RK4; one call site of the inlined _derivatives for the four stages
        for stage in range(4):
            _derivatives(state if stage == 0 else work, u, p, directions, m, d, slopes, stage)
            if stage < 3:
                step = half if stage < 2 else dt
                for r in range(nx):
                    work[r] = state[r] + step * slopes[stage, r]
        for r in range(nx):
            state[r] += sixth * (
                slopes[0, r] + 2.0 * slopes[1, r] + 2.0 * slopes[2, r] + slopes[3, r]
            )


@njit(cache=True, error_model="numpy")
def simulate_compiled(
    state: FloatArray,
    buffer: FloatArray,
    head: IntArray,
    commands: FloatArray,
    noise: FloatArray,
    p: FloatArray,
    directions: FloatArray,
    n_sub: int,
    dt: float,
    outputs: FloatArray,
    motor_position: FloatArray,
    motor_velocity: FloatArray,
) -> None:  # pragma: no cover - compiled; checked against simulate_reference
    """Advance ``state`` over ``commands.shape[0]`` samples (RK4, ``n_sub`` sub-steps of ``dt``).

    Row ``k`` of the outputs is measured at the start of sample ``k`` (before ``commands[k]``
    acts): the tilt sensor reads the bending ``delay = buffer.shape[0] - 1`` samples old.
    ``state``, ``buffer`` and ``head`` are updated in place.
    """
    nx = state.shape[0]
    slopes = np.empty((4, nx))
    work = np.empty(nx)
    u = np.empty(directions.shape[0])
    for k in range(commands.shape[0]):
        for i in range(u.shape[0]):
            u[i] = commands[k, i]
        _sample(
            state,
            buffer,
            head,
            u,
            noise,
            p,
            directions,
            n_sub,
            dt,
            outputs,
            motor_position,
            motor_velocity,
            k,
            slopes,
            work,
        )


@njit(cache=True, error_model="numpy")
def closed_loop_compiled(
    state: FloatArray,
    buffer: FloatArray,
    head: IntArray,
    reference: FloatArray,
    excitation: FloatArray,
    noise: FloatArray,
    p: FloatArray,
    directions: FloatArray,
    n_sub: int,
    dt: float,
    gains: FloatArray,
    tendon_cos: FloatArray,
    tendon_sin: FloatArray,
    integral: FloatArray,
    commands: FloatArray,
    outputs: FloatArray,
    motor_position: FloatArray,
    motor_velocity: FloatArray,
) -> int:  # pragma: no cover - compiled; checked against the generic loop of closed_loop
    """The PI inclination loop around the neck, sample by sample, as :func:`closed_loop` runs it.

    ``gains`` holds ``(kp, ki * ts, command_limit)``; ``reference`` has 1 column (planar: the
    inclination) or 2 (inclination, orientation [deg]); ``integral`` (1 or 2 values) is the PI's
    state, updated in place. Command ``k`` is computed from output ``k - 1`` (zero at first),
    plus ``excitation[k]``, then the neck advances one sample as :func:`simulate_compiled` does.
    Returns the number of samples run: ``reference.shape[0]``, or fewer when the state stopped
    being finite (the sample where it did included).
    """
    n = reference.shape[0]
    m = directions.shape[0]
    nx = state.shape[0]
    planar = reference.shape[1] == 1
    kp, ki_ts, limit = gains[0], gains[1], gains[2]
    slopes = np.empty((4, nx))
    work = np.empty(nx)
    error = np.zeros(2)
    candidate = np.zeros(2)
    wanted = np.zeros(2)
    raw = np.empty(m)
    measurement0 = 0.0
    measurement1 = 0.0
    for k in range(n):
        # the PI law (InclinationController.control_law), on the error of the bending vector
        if planar:
            error[0] = reference[k, 0] - measurement0
        else:
            angle = math.radians(reference[k, 1])
            seen = math.radians(measurement1)
            error[0] = reference[k, 0] * math.cos(angle) - measurement0 * math.cos(seen)
            error[1] = reference[k, 0] * math.sin(angle) - measurement0 * math.sin(seen)
        n_int = 1 if planar else 2
        for j in range(n_int):
            candidate[j] = integral[j] + ki_ts * error[j]
            wanted[j] = kp * error[j] + candidate[j]
        peak = 0.0
        for i in range(m):
            raw[i] = wanted[0] if planar else tendon_cos[i] * wanted[0] + tendon_sin[i] * wanted[1]
            peak = max(peak, abs(raw[i]))
        saturated = peak > limit
        scale = limit / peak if saturated else 1.0
        push = error[0] * wanted[0] + (0.0 if planar else error[1] * wanted[1])
        if not saturated or push < 0.0:
            for j in range(n_int):
                integral[j] = candidate[j]
        for i in range(m):
            commands[k, i] = (raw[i] * scale if saturated else raw[i]) + excitation[k, i]
        _sample(
            state,
            buffer,
            head,
            commands[k],
            noise,
            p,
            directions,
            n_sub,
            dt,
            outputs,
            motor_position,
            motor_velocity,
            k,
            slopes,
            work,
        )
        for r in range(nx):
            if not math.isfinite(state[r]):
                return k + 1
        measurement0 = outputs[k, 0]
        if not planar:
            measurement1 = outputs[k, 1]
    return n


# ---------------------------------------------------------------------------------------------
# plain NumPy reference (same equations, vectorised over tendons and components)
# ---------------------------------------------------------------------------------------------
def _shape_functions_reference(theta: float) -> tuple[float, float, float, float]:
    if theta < SMALL_ANGLE:
        t2 = theta**2
        return (
            1.0 - t2 / 24.0 + t2**2 / 1920.0,
            -1.0 / 12.0 + t2 / 480.0 - t2**2 / 53760.0,
            1.0 / 3.0 - t2 / 30.0 + t2**2 / 840.0,
            1.0 - t2 / 6.0 + t2**2 / 120.0,
        )
    return (
        2.0 * np.sin(theta / 2) / theta,
        (np.cos(theta / 2) / theta - 2.0 * np.sin(theta / 2) / theta**2) / theta,
        (np.sin(theta) - theta * np.cos(theta)) / theta**3,
        np.sin(theta) / theta,
    )


def tendon_state_reference(
    x: FloatArray, p: FloatArray, directions: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Tendon stretch [m], length gradient d l / d b [m/rad] (rows: tendons) and force [N]."""
    m, d = directions.shape
    q, w = x[:m], x[m : 2 * m]
    b, v = x[2 * m : 2 * m + d], x[2 * m + d : 2 * m + 2 * d]
    theta = float(np.sqrt(np.sum(b**2)))
    s, sp_over, _, _ = _shape_functions_reference(theta)
    length, radius, winch = p[LINK_LENGTH], p[ANCHOR_RADIUS], p[WINCH_RADIUS]
    lever = length - radius * (directions @ b)
    stretch = winch * q - (length - s * lever)
    grad = sp_over * lever[:, None] * b[None, :] - s * radius * directions
    force = p[TENDON_STIFFNESS] * stretch + p[TENDON_DAMPING] * (winch * w + grad @ v)
    force = np.where(stretch > 0.0, np.maximum(force, 0.0), 0.0)
    return stretch, grad, force


def derivatives_reference(
    x: FloatArray, u: FloatArray, p: FloatArray, directions: FloatArray
) -> FloatArray:
    """Time derivative of the state (NumPy reference of the compiled ``_derivatives``)."""
    m, d = directions.shape
    w = x[m : 2 * m]
    b = x[2 * m : 2 * m + d]
    v = x[2 * m + d : 2 * m + 2 * d]
    z = x[2 * m + 2 * d :]
    theta = float(np.sqrt(np.sum(b**2)))
    _, _, a, sinc = _shape_functions_reference(theta)
    _, grad, force = tendon_state_reference(x, p, directions)
    target = np.clip(u, -p[MOTOR_SPEED_LIMIT], p[MOTOR_SPEED_LIMIT])
    target = np.where((force >= p[TENDON_FORCE_LIMIT]) & (target > 0.0), 0.0, target)
    acc = np.clip(
        (target - w) / p[MOTOR_TIME_CONSTANT],
        -p[MOTOR_ACCELERATION_LIMIT],
        p[MOTOR_ACCELERATION_LIMIT],
    )
    moment = (
        -p[STIFFNESS] * (1.0 + p[STIFFENING] * theta) * b
        - p[HYSTERESIS_STIFFNESS] * (1.0 + 2.0 * p[STIFFENING] * theta) * z
        - p[DAMPING] * (1.0 + p[DAMPING_GROWTH] * theta) * v
        + (p[GRAVITY_ARC] * a + p[GRAVITY_HEAD] * sinc) * b
        - force @ grad
    )
    dz = v * (1.0 - (p[BOUC_WEN_BETA] * np.sign(v * z) + p[BOUC_WEN_GAMMA]) * np.abs(z))
    return np.concatenate([w, acc, v, moment / p[INERTIA], dz])


def measure_reference(bending: FloatArray, noise: FloatArray, p: FloatArray) -> FloatArray:
    """Tilt-sensor reading [deg] of a (delayed) bending vector: noise, magnitude, quantisation."""
    resolution = p[SENSOR_RESOLUTION]
    vector = bending * RAD2DEG + p[SENSOR_NOISE] * noise
    incl = np.floor(np.sqrt(np.sum(vector**2)) / resolution + 0.5) * resolution
    if bending.shape[0] == 1:
        return np.array([incl])
    orient = np.degrees(np.arctan2(vector[1], vector[0])) % 360.0
    orient = np.floor(orient / resolution + 0.5) * resolution
    return np.array([incl, orient - 360.0 if orient >= 360.0 else orient])


def simulate_reference(
    state: FloatArray,
    buffer: FloatArray,
    head: IntArray,
    commands: FloatArray,
    noise: FloatArray,
    p: FloatArray,
    directions: FloatArray,
    n_sub: int,
    dt: float,
    outputs: FloatArray,
    motor_position: FloatArray,
    motor_velocity: FloatArray,
) -> None:
    """Plain NumPy reference of :func:`simulate_compiled` (same arguments, same effect)."""
    m, d = directions.shape
    slots = buffer.shape[0]
    for k in range(commands.shape[0]):
        h = int(head[0])
        buffer[h] = state[2 * m : 2 * m + d]
        oldest = (h + 1) % slots
        outputs[k] = measure_reference(buffer[oldest], noise[k], p)
        head[0] = oldest
        motor_position[k] = state[:m]
        motor_velocity[k] = state[m : 2 * m]
        u = commands[k]
        for _ in range(n_sub):
            k1 = derivatives_reference(state, u, p, directions)
            k2 = derivatives_reference(state + 0.5 * dt * k1, u, p, directions)
            k3 = derivatives_reference(state + 0.5 * dt * k2, u, p, directions)
            k4 = derivatives_reference(state + dt * k3, u, p, directions)
            state += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
