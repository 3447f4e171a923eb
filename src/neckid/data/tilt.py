r"""The tilt of the 3-D neck's top platform, in representations that do not wrap.

A tilt sensor (or an IMU) on the platform reports the **inclination** :math:`i \ge 0` (the angle
between the platform's normal and the base's axis) and the **orientation** :math:`\varphi` (the
direction the neck leans to, in [0, 360)°, counter-clockwise from tendon 1). That pair is polar
coordinates: the orientation wraps at 0/360° and is undefined at zero inclination, so a model that
identifies it directly sees jumps of 360° whenever the neck leans towards 0°, and noise of ±180°
whenever it passes upright. Two wrap-free representations are offered:

* the **tilt vector** (``tilt_x``, ``tilt_y``) [deg], the Cartesian form of the same polar pair:

  .. math:: t_x = i\cos\varphi, \qquad t_y = i\sin\varphi.

  It is the constant-curvature bending vector of the link (:mod:`neckid.plant.soft_neck`), so
  the simulated neck's dynamics are smooth in it; it is the rotation vector of the platform
  turned by 90° (the platform turns by :math:`i` about the axis :math:`(-\sin\varphi,
  \cos\varphi, 0)`). This is what neckid identifies on the 3-D neck.
* **pitch and roll** [deg], the angles the 3-D paper identifies (Quevedo et al. 2021), with the
  convention: roll about the base's x axis first, then pitch about its y axis,
  :math:`R = R_y(\text{pitch})\,R_x(\text{roll})`, so the platform normal is
  :math:`n = (\cos r \sin p,\; -\sin r,\; \cos r \cos p)` and, from the tilt,
  :math:`n = (\sin i\cos\varphi,\; \sin i\sin\varphi,\; \cos i)`. For small tilts
  pitch ≈ :math:`t_x` and roll ≈ :math:`-t_y`.

Back from either: :math:`i = \sqrt{t_x^2 + t_y^2}` (or :math:`\arccos n_z`) and
:math:`\varphi = \operatorname{atan2}(t_y, t_x)` taken in [0, 360); at zero inclination the
orientation is reported as 0° by convention (any value describes the same platform pose).

References
----------
.. [1] Quevedo, F., Muñoz, J., Castano Pena, J. A., Monje, C. A. "3D Model Identification of a
   Soft Robotic Neck." Mathematics 9(14):1652, 2021 (pitch and roll of the same neck).
.. [2] Webster, R. J., Jones, B. A. "Design and kinematic modeling of constant curvature continuum
   robots: a review." Int. J. Robotics Research 29(13), 2010 (bending angle and direction).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal, Protocol, Self, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from neckid.utils.checks import check_finite
from neckid.utils.types import FloatArray


class _Log(Protocol):
    """What the conversions need of a log (an :class:`~neckid.IOData`); tilt does not import it."""

    @property
    def y(self) -> FloatArray: ...  # pragma: no cover - protocol

    @property
    def output_names(self) -> tuple[str, ...]: ...  # pragma: no cover - protocol

    @property
    def output_units(self) -> tuple[str, ...]: ...  # pragma: no cover - protocol

    def channel(self, name: str) -> FloatArray: ...  # pragma: no cover - protocol

    def select(
        self, inputs: Sequence[str] | None = None, outputs: Sequence[str] | None = None
    ) -> Self: ...  # pragma: no cover - protocol

    def replace(self, **changes: Any) -> Self: ...  # pragma: no cover - protocol


#: An :class:`~neckid.IOData` (or any log with the same methods): what goes in comes out.
LogT = TypeVar("LogT", bound=_Log)

__all__ = [
    "Representation",
    "from_pitch_roll",
    "from_tilt",
    "polar_log",
    "tilt_log",
    "to_pitch_roll",
    "to_tilt",
]

Representation = Literal["vector", "pitch_roll"]

#: Channel names of each representation, in order.
NAMES: dict[str, tuple[str, str]] = {
    "vector": ("tilt_x", "tilt_y"),
    "pitch_roll": ("pitch", "roll"),
}


def _pair(a: ArrayLike, b: ArrayLike, names: tuple[str, str]) -> tuple[FloatArray, FloatArray]:
    first = np.asarray(a, dtype=np.float64)
    second = np.asarray(b, dtype=np.float64)
    if first.shape != second.shape:
        raise ValueError(
            f"{names[0]} and {names[1]} must have the same shape; got {first.shape} and"
            f" {second.shape}"
        )
    for values, name in ((first, names[0]), (second, names[1])):
        check_finite(values.reshape(-1, 1), name)
    return first, second


def to_tilt(inclination: ArrayLike, orientation: ArrayLike) -> tuple[FloatArray, FloatArray]:
    r"""The tilt vector (``tilt_x``, ``tilt_y``) [deg] from inclination and orientation [deg].

    Parameters
    ----------
    inclination : array_like
        Inclination [deg], >= 0 (a negative value is read as leaning the other way).
    orientation : array_like
        Orientation [deg], any range (360° apart give the same tilt).

    Returns
    -------
    tilt_x, tilt_y : ndarray
        :math:`i\cos\varphi` and :math:`i\sin\varphi` [deg], the shape of the inputs.

    Raises
    ------
    ValueError
        If the shapes differ or a value is NaN or inf.

    Examples
    --------
    >>> from neckid.data.tilt import to_tilt
    >>> x, y = to_tilt([10.0, 10.0], [0.0, 360.0])      # the same pose: no jump
    >>> x.tolist(), [round(v, 12) for v in y.tolist()]
    ([10.0, 10.0], [0.0, -0.0])
    """
    incl, orient = _pair(inclination, orientation, ("inclination", "orientation"))
    angle = np.radians(orient)
    return incl * np.cos(angle), incl * np.sin(angle)


def from_tilt(tilt_x: ArrayLike, tilt_y: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Inclination [deg] (>= 0) and orientation [deg] in [0, 360) from the tilt vector [deg].

    Zero inclination gets orientation 0° (the direction is undefined there).

    Examples
    --------
    >>> from neckid.data.tilt import from_tilt
    >>> incl, orient = from_tilt([0.0, -3.0], [0.0, -4.0])
    >>> incl.tolist(), [round(v, 6) for v in orient.tolist()]
    ([0.0, 5.0], [0.0, 233.130102])
    """
    x, y = _pair(tilt_x, tilt_y, ("tilt_x", "tilt_y"))
    inclination = np.hypot(x, y)
    orientation = np.mod(np.degrees(np.arctan2(y, x)), 360.0)
    orientation = np.where(inclination > 0.0, orientation, 0.0)
    # mod can return 360.0 itself for angles a rounding step below 0
    return inclination, np.where(orientation >= 360.0, 0.0, orientation)


def to_pitch_roll(inclination: ArrayLike, orientation: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Pitch and roll [deg] (roll about x, then pitch about y) from inclination and orientation.

    Examples
    --------
    >>> from neckid.data.tilt import to_pitch_roll
    >>> pitch, roll = to_pitch_roll([30.0, 30.0], [0.0, 90.0])
    >>> [round(v, 9) for v in pitch.tolist()], [round(v, 9) for v in roll.tolist()]
    ([30.0, 0.0], [-0.0, -30.0])
    """
    incl, orient = _pair(inclination, orientation, ("inclination", "orientation"))
    i, phi = np.radians(incl), np.radians(orient)
    nx, ny, nz = np.sin(i) * np.cos(phi), np.sin(i) * np.sin(phi), np.cos(i)
    return np.degrees(np.arctan2(nx, nz)), np.degrees(-np.arcsin(np.clip(ny, -1.0, 1.0)))


def from_pitch_roll(pitch: ArrayLike, roll: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Inclination [deg] and orientation [deg] in [0, 360) from pitch and roll [deg].

    Examples
    --------
    >>> from neckid.data.tilt import from_pitch_roll
    >>> incl, orient = from_pitch_roll([0.0], [-30.0])
    >>> round(float(incl[0]), 9), round(float(orient[0]), 9)
    (30.0, 90.0)
    """
    p, r = _pair(pitch, roll, ("pitch", "roll"))
    p, r = np.radians(p), np.radians(r)
    nx, ny, nz = np.cos(r) * np.sin(p), -np.sin(r), np.cos(r) * np.cos(p)
    inclination = np.degrees(np.arctan2(np.hypot(nx, ny), nz))  # arccos(n_z), exact near 0
    orientation = np.mod(np.degrees(np.arctan2(ny, nx)), 360.0)
    orientation = np.where((inclination > 0.0) & (orientation < 360.0), orientation, 0.0)
    return inclination, orientation


def tilt_log(
    data: LogT,
    *,
    inclination: str = "inclination",
    orientation: str = "orientation",
    representation: Representation = "vector",
) -> LogT:
    """The log with its inclination and orientation outputs replaced by a wrap-free pair.

    Parameters
    ----------
    data : IOData
        A log with outputs named ``inclination`` and ``orientation`` [deg].
    inclination, orientation : str
        The names of those outputs in ``data``.
    representation : {"vector", "pitch_roll"}, default "vector"
        ``"vector"``: outputs ``tilt_x``, ``tilt_y``; ``"pitch_roll"``: ``pitch``, ``roll``
        (in place of the two, other outputs kept after them), all [deg].

    Returns
    -------
    IOData
        Inputs, conditions and name unchanged.

    Raises
    ------
    KeyError
        If an output is missing (the message names it and lists the outputs).
    ValueError
        If ``representation`` is neither.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> from neckid.data.tilt import tilt_log
    >>> log = IOData(np.zeros(2), np.array([[5.0, 359.0], [5.0, 1.0]]), ts=0.02,
    ...              output_names=["inclination", "orientation"], output_units=["deg", "deg"])
    >>> tilt_log(log).output_names
    ('tilt_x', 'tilt_y')
    """
    if representation not in NAMES:
        raise ValueError(f"representation must be 'vector' or 'pitch_roll'; got {representation!r}")
    for name, role in ((inclination, "inclination"), (orientation, "orientation")):
        if name not in data.output_names:
            raise KeyError(
                f"{role} output {name!r} not in the log; its outputs are {list(data.output_names)}"
            )
    convert = to_tilt if representation == "vector" else to_pitch_roll
    first, second = convert(data.channel(inclination), data.channel(orientation))
    return _swap_outputs(data, (inclination, orientation), NAMES[representation], first, second)


def polar_log(data: LogT, *, representation: Representation = "vector") -> LogT:
    """The inverse of :func:`tilt_log`: outputs ``inclination`` and ``orientation`` [deg] again.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> from neckid.data.tilt import polar_log
    >>> log = IOData(np.zeros(1), np.array([[3.0, 4.0]]), ts=0.02, output_names=["tilt_x", "tilt_y"])
    >>> polar_log(log).y.tolist()
    [[5.0, 53.13010235415598]]
    """
    if representation not in NAMES:
        raise ValueError(f"representation must be 'vector' or 'pitch_roll'; got {representation!r}")
    names = NAMES[representation]
    for name in names:
        if name not in data.output_names:
            raise KeyError(
                f"output {name!r} not in the log; its outputs are {list(data.output_names)}"
            )
    convert = from_tilt if representation == "vector" else from_pitch_roll
    first, second = convert(data.channel(names[0]), data.channel(names[1]))
    return _swap_outputs(data, names, ("inclination", "orientation"), first, second)


def _swap_outputs(
    data: LogT,
    old: tuple[str, str],
    new: tuple[str, str],
    first: FloatArray,
    second: FloatArray,
) -> LogT:
    others = [name for name in data.output_names if name not in old]
    kept = data.select(outputs=others) if others else None
    y = np.column_stack([first, second, *(kept.y.T if kept is not None else [])])
    units = ("deg", "deg", *(kept.output_units if kept is not None else ()))
    return data.replace(y=y, output_names=(*new, *others), output_units=units)
