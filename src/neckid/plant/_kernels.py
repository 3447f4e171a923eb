"""Inner loop of the simulated soft neck: a compiled kernel and the plain NumPy reference beside it.

Both functions advance the same state with the same equations (documented in
:mod:`neckid.plant.soft_neck`) and must agree to rounding; ``tests/test_plant.py`` checks it.
The public wrapper (:class:`neckid.plant.SoftNeck`) validates, casts to contiguous ``float64``
and allocates; the kernels only loop.

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
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

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

SMALL_ANGLE = 1e-2  # below this bending angle [rad] the series expansions are used
RAD2DEG = 180.0 / math.pi


# ---------------------------------------------------------------------------------------------
# compiled kernel
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def _shape_functions(theta: float) -> tuple[float, float, float, float]:  # pragma: no cover
    """S = 2 sin(theta/2)/theta, S'/theta, A = (sin - theta cos)/theta^3, sinc = sin(theta)/theta."""
    if theta < SMALL_ANGLE:
        t2 = theta * theta
        t4 = t2 * t2
        s = 1.0 - t2 / 24.0 + t4 / 1920.0
        sp_over = -1.0 / 12.0 + t2 / 480.0 - t4 / 53760.0
        a = 1.0 / 3.0 - t2 / 30.0 + t4 / 840.0
        sinc = 1.0 - t2 / 6.0 + t4 / 120.0
    else:
        half_sin = math.sin(0.5 * theta)
        s = 2.0 * half_sin / theta
        sp_over = (math.cos(0.5 * theta) / theta - 2.0 * half_sin / (theta * theta)) / theta
        sin_t = math.sin(theta)
        a = (sin_t - theta * math.cos(theta)) / (theta * theta * theta)
        sinc = sin_t / theta
    return s, sp_over, a, sinc


@njit(cache=True)
def _derivatives(
    x: FloatArray,
    u: FloatArray,
    p: FloatArray,
    directions: FloatArray,
    m: int,
    d: int,
    dx: FloatArray,
) -> None:  # pragma: no cover - compiled; checked against _derivatives_reference
    length = p[LINK_LENGTH]
    radius = p[ANCHOR_RADIUS]
    winch = p[WINCH_RADIUS]
    ib = 2 * m
    iv = 2 * m + d
    iz = 2 * m + 2 * d
    theta2 = 0.0
    for j in range(d):
        theta2 += x[ib + j] * x[ib + j]
    theta = math.sqrt(theta2)
    s, sp_over, a, sinc = _shape_functions(theta)
    # motors: first-order velocity loop with command saturation and acceleration limit; a drive
    # pulling with the force limit stalls (winds no further)
    w_max = p[MOTOR_SPEED_LIMIT]
    a_max = p[MOTOR_ACCELERATION_LIMIT]
    for i in range(m):
        target = min(max(u[i], -w_max), w_max)
        dx[i] = x[m + i]
        dx[m + i] = target  # finished below, once the tendon force is known
    # generalised forces on the bending vector
    stiff = p[STIFFNESS] * (1.0 + p[STIFFENING] * theta)
    tangent = p[HYSTERESIS_STIFFNESS] * (1.0 + 2.0 * p[STIFFENING] * theta)
    damp = p[DAMPING] * (1.0 + p[DAMPING_GROWTH] * theta)
    grav = p[GRAVITY_ARC] * a + p[GRAVITY_HEAD] * sinc
    for j in range(d):
        dx[ib + j] = x[iv + j]
        dx[iv + j] = -stiff * x[ib + j] - tangent * x[iz + j] - damp * x[iv + j] + grav * x[ib + j]
    for i in range(m):
        proj = 0.0
        for j in range(d):
            proj += directions[i, j] * x[ib + j]
        lever = length - radius * proj
        tendon_length = s * lever
        stretch = winch * x[i] - (length - tendon_length)
        if stretch <= 0.0:
            continue
        length_rate = 0.0
        for j in range(d):
            grad = sp_over * lever * x[ib + j] - s * radius * directions[i, j]
            length_rate += grad * x[iv + j]
        force = p[TENDON_STIFFNESS] * stretch + p[TENDON_DAMPING] * (winch * x[m + i] + length_rate)
        if force <= 0.0:
            continue
        if force >= p[TENDON_FORCE_LIMIT] and dx[m + i] > 0.0:
            dx[m + i] = 0.0
        for j in range(d):
            grad = sp_over * lever * x[ib + j] - s * radius * directions[i, j]
            dx[iv + j] -= force * grad
    for i in range(m):
        acc = (dx[m + i] - x[m + i]) / p[MOTOR_TIME_CONSTANT]
        dx[m + i] = min(max(acc, -a_max), a_max)
    inertia = p[INERTIA]
    for j in range(d):
        dx[iv + j] /= inertia
    # Bouc-Wen (n = 1, A = 1): dz = db (1 - (beta sgn(db z) + gamma) |z|)
    for j in range(d):
        rate = x[iv + j]
        zj = x[iz + j]
        sgn = 1.0 if rate * zj > 0.0 else (-1.0 if rate * zj < 0.0 else 0.0)
        dx[iz + j] = rate * (1.0 - (p[BOUC_WEN_BETA] * sgn + p[BOUC_WEN_GAMMA]) * abs(zj))


@njit(cache=True)
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


@njit(cache=True)
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
    n = commands.shape[0]
    m = directions.shape[0]
    d = directions.shape[1]
    nx = state.shape[0]
    slots = buffer.shape[0]
    ib = 2 * m
    k1 = np.empty(nx)
    k2 = np.empty(nx)
    k3 = np.empty(nx)
    k4 = np.empty(nx)
    tmp = np.empty(nx)
    u = np.empty(m)
    for k in range(n):
        h = head[0]
        for j in range(d):
            buffer[h, j] = state[ib + j]
        oldest = (h + 1) % slots
        _measure(buffer[oldest], noise[k], p, d, outputs[k])
        head[0] = oldest
        for i in range(m):
            motor_position[k, i] = state[i]
            motor_velocity[k, i] = state[m + i]
            u[i] = commands[k, i]
        for _ in range(n_sub):
            _derivatives(state, u, p, directions, m, d, k1)
            for r in range(nx):
                tmp[r] = state[r] + 0.5 * dt * k1[r]
            _derivatives(tmp, u, p, directions, m, d, k2)
            for r in range(nx):
                tmp[r] = state[r] + 0.5 * dt * k2[r]
            _derivatives(tmp, u, p, directions, m, d, k3)
            for r in range(nx):
                tmp[r] = state[r] + dt * k3[r]
            _derivatives(tmp, u, p, directions, m, d, k4)
            for r in range(nx):
                state[r] += dt / 6.0 * (k1[r] + 2.0 * k2[r] + 2.0 * k3[r] + k4[r])


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
