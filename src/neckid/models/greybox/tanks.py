r"""The cascaded tanks as a grey-box structure: power-law outflows and the tanks' overflows.

The benchmark plant (Schoukens, Mattsson, Wigren & Noël 2016): a pump lifts water from a
reservoir into the upper tank, which drains through a small opening into the lower tank, which
drains back into the reservoir; the output is the lower tank's level sensor [V]. Its physical
model (eq. (1)–(2) of the benchmark description, from Bernoulli's law) is

.. math::

    \dot x_1 = -k_1 \sqrt{x_1} + k_4 u, \qquad \dot x_2 = k_2 \sqrt{x_1} - k_3 \sqrt{x_2},
    \qquad y = x_2,

valid while neither tank overflows. This structure adds what the description says happens
beyond that (both tanks overflow in the benchmark's records: the hard nonlinearity) and what a
real rig adds: the pump's dead zone, the height of the lower outlet, and outflow laws whose
exponents are parameters (Torricelli's 1/2 is the initial guess; an outlet pipe in laminar
flow tends to 1, and a level sensor that is not linear in the level bends the lower one):

.. math::

    \dot x_1 = k_4 \max(u - u_0, 0) - k_1 x_1^{a_1}, \qquad
    \dot x_2 = k_1 x_1^{a_1} - k_3 \max(x_2 - x_o, 0)^{a_2}, \qquad y = x_2,

and, after every integration step, the overflows as saturations (the structure's
``saturation``): the water above the upper tank's capacity :math:`h_1` leaves it, a share
:math:`s` falls into the lower tank and the rest returns to the reservoir; the lower tank holds
at most :math:`h_2`,

.. math::

    e = \max(x_1 - h_1, 0), \qquad x_1 \leftarrow x_1 - e, \qquad
    x_2 \leftarrow \min(x_2 + s\,e,\ h_2).

``x_2`` is the lower level as the sensor reads it [V]; ``x_1`` is the upper tank's water volume
divided by the lower tank's cross-section, in the same volts, so that the water leaving one tank
enters the other unchanged (:math:`k_2 = k_1`: the one scale of the unmeasured state that the
data cannot fix). ``u_0`` is the pump's dead zone, ``x_o`` the sensor's reading at the lower
outlet, ``h_1`` and ``h_2`` the tanks' capacities; the lower tank's overflow holds its level at
``h_2``, where the sensor reads its largest value.

Initial state (``GreyBoxODE(initial_state="output")``): ``x_2(0) = y(0)`` held in
``[0, h_2]``, and the upper tank in balance with the lower one (what flows in flows out),
:math:`x_1(0) = \min\bigl((k_3 \max(x_2(0) - x_o, 0)^{a_2} / k_1)^{1/a_1},\ h_1\bigr)`.

References
----------
M. Schoukens, P. Mattsson, T. Wigren and J.-P. Noël, "Cascaded tanks benchmark combining soft
and hard nonlinearities", Workshop on Nonlinear System Identification Benchmarks, Brussels, 2016
(the model without overflow, eq. (1)–(2), and the account of the overflow).

M. Forgione and D. Piga, "Continuous-time system identification with neural networks: model
structures and fitting criteria", *European Journal of Control* 59, 69–81, 2021 (a two-state
continuous-time model with the upper tank's overflow reaching the lower tank).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from neckid.models.greybox.structure import GreyBoxStructure, StructureParameter
from neckid.utils.types import FloatArray

__all__ = ["CASCADED_TANKS"]

# Parameter order: p[0] k1, p[1] a1, p[2] k3, p[3] a2, p[4] k4, p[5] u0, p[6] x_o, p[7] h1,
# p[8] s, p[9] h2.

# fmt: off
_PARAMETERS = (
    StructureParameter("upper_outflow", 0.05, 1e-3, 1.0, "V^(1-a1)/s",
                       "k1: outflow coefficient of the upper tank's outlet", log_scale=True),
    StructureParameter("upper_exponent", 0.5, 0.2, 1.0, "",
                       "a1: exponent of the upper outflow law (1/2: Torricelli)"),
    StructureParameter("lower_outflow", 0.05, 1e-3, 1.0, "V^(1-a2)/s",
                       "k3: outflow coefficient of the lower tank's outlet", log_scale=True),
    StructureParameter("lower_exponent", 0.5, 0.2, 1.0, "",
                       "a2: exponent of the lower outflow law (1/2: Torricelli)"),
    StructureParameter("pump_gain", 0.05, 1e-3, 1.0, "1/s",
                       "k4: level rate per pump volt above the dead zone", log_scale=True),
    StructureParameter("pump_threshold", 0.0, 0.0, 2.0, "V",
                       "u0: pump voltage below which nothing flows"),
    StructureParameter("lower_outlet", 0.0, -5.0, 5.0, "V",
                       "x_o: sensor reading at the lower tank's outlet"),
    StructureParameter("upper_capacity", 10.0, 1.0, 50.0, "V",
                       "h1: upper content above which it overflows"),
    StructureParameter("overflow_share", 0.5, 0.0, 1.0, "",
                       "s: share of the upper tank's overflow falling into the lower tank"),
    StructureParameter("lower_capacity", 10.0, 5.0, 20.0, "V",
                       "h2: lower level above which it overflows"),
)
# fmt: on


@njit(cache=True)
def _tanks_state(x: FloatArray, u: FloatArray, p: FloatArray) -> FloatArray:
    """``dx/dt`` of the two tanks [V/s]: pump in, outflow laws between and out."""
    inflow = p[4] * max(u[0] - p[5], 0.0)
    between = p[0] * max(x[0], 0.0) ** p[1]
    outflow = p[2] * max(x[1] - p[6], 0.0) ** p[3]
    return np.array([inflow - between, between - outflow])


@njit(cache=True)
def _tanks_overflow(x: FloatArray, u: FloatArray, p: FloatArray) -> FloatArray:
    """The overflows: the upper tank's excess (a share into the lower one), the lower's cap."""
    excess = max(x[0] - p[7], 0.0)
    return np.array([x[0] - excess, min(x[1] + p[8] * excess, p[9])])


@njit(cache=True)
def _tanks_output(x: FloatArray, u: FloatArray, p: FloatArray) -> FloatArray:
    """``y = x_2``: the lower tank's level sensor [V]."""
    return np.array([x[1]])


@njit(cache=True)
def _tanks_initial(y0: FloatArray, u0: FloatArray, p: FloatArray) -> FloatArray:
    """``x(0)`` from the first level: the lower tank as measured, the upper one in balance."""
    lower = min(max(y0[0], 0.0), p[9])
    outflow = p[2] * max(lower - p[6], 0.0) ** p[3]
    upper = min((outflow / p[0]) ** (1.0 / p[1]), p[7])
    return np.array([upper, lower])


CASCADED_TANKS = GreyBoxStructure(
    name="cascaded-tanks",
    state_equation=_tanks_state,
    output_equation=_tanks_output,
    initial_state=_tanks_initial,
    saturation=_tanks_overflow,
    parameters=_PARAMETERS,
    state_names=("upper_content", "lower_level"),
    state_units=("V", "V"),
    n_inputs=1,
    n_outputs=1,
    state_lower=(0.0, -math.inf),
    description=(
        "Two cascaded tanks, pump voltage -> lower level [V]: power-law outflows (Torricelli's"
        " square root by default), the pump's dead zone, the lower outlet's height, the upper"
        " tank's overflow (a share reaching the lower tank) and the lower tank's overflow"
        " (Schoukens et al. 2016)."
    ),
    references=(
        "M. Schoukens, P. Mattsson, T. Wigren, J.-P. Noel, Cascaded tanks benchmark combining"
        " soft and hard nonlinearities, Workshop on Nonlinear System Identification Benchmarks,"
        " 2016",
    ),
)
