r"""A model's frequency response over a measured one, and the figure of merit.

The measured response is the robust BLA of a multisine log (:func:`~neckid.frequency.robust_bla`,
with its 95 % band from the noise and the stochastic nonlinear distortions) or, for any other log,
the Welch estimate (:func:`~neckid.frequency.smoothed_frf`, band from the coherence). The model's
response is

- for a linear model with the log's one input: its transfer function (:func:`neckid.to_control`;
  a gain-scheduled model frozen at the log's mean inclination);
- for any other model (Set Membership, neural, polynomial, a model with several inputs): the same
  estimator applied to its free run on the log's own inputs, i.e. its BLA on the same multisine.

Notes
-----
The figure of merit is the share of lines where :math:`|G_{model} - \hat G| \le r_{95}` and the
weighted error :math:`\sqrt{\frac1F\sum_k |G_{model}(k) - \hat G(k)|^2 / r_{95}(k)^2}`: the error
in units of the band's radius, below 1 when the model lies inside the band on average.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from neckid.frequency.bla import BestLinearApproximation, robust_bla
from neckid.frequency.spectral import FrequencyResponse, smoothed_frf
from neckid.utils.types import FloatArray

__all__ = ["FrequencyFit", "frequency_fit", "measured_response", "model_response"]


@dataclass(frozen=True)
class FrequencyFit:
    """A model's response against a measured one, at the measured frequencies.

    Attributes
    ----------
    omega : ndarray
        rad/s.
    model_frf, measured_frf : complex ndarray
    band_radius : ndarray
        The measured estimate's 95 % radius.
    share_inside : float
        Share of the frequencies where the model lies inside that band, in [0, 1].
    weighted_error : float
        RMS of ``|model - measured| / band_radius`` (below 1: inside on average).
    model_estimate, measured_estimate : str
        How each response was obtained.
    """

    omega: FloatArray
    model_frf: Any
    measured_frf: Any
    band_radius: FloatArray
    share_inside: float
    weighted_error: float
    model_estimate: str
    measured_estimate: str

    def to_dict(self) -> dict[str, Any]:
        """The figures of merit and how both responses were obtained."""
        return {
            "share_inside_95": self.share_inside,
            "weighted_error": self.weighted_error,
            "n_frequencies": int(self.omega.size),
            "model_estimate": self.model_estimate,
            "measured_estimate": self.measured_estimate,
        }


def measured_response(
    u: FloatArray,
    y: FloatArray,
    ts: float,
    multisine: tuple[int, int, int] | None,
    names: tuple[tuple[str, ...], tuple[str, ...]] | None = None,
    units: tuple[tuple[str, ...], tuple[str, ...]] | None = None,
) -> BestLinearApproximation | FrequencyResponse:
    """The robust BLA (``multisine=(M, P, T)``) or the Welch estimate of one input and output."""
    if multisine is None:
        return smoothed_frf(u, y, ts)
    m, p, t = multisine
    period, rest = divmod(u.shape[0], m * (p + t))
    if rest or period < 8:
        raise ValueError(
            f"the log's {u.shape[0]} samples are not {m} realisations x ({t} + {p}) periods of a"
            " whole number (>= 8) of samples"
        )
    return robust_bla(
        u.reshape(-1, 1),
        y.reshape(-1, 1),
        ts,
        period=period,
        n_realisations=m,
        n_periods=p,
        transient_periods=t,
        names=names,
        units=units,
    )


def _pair(response: BestLinearApproximation | FrequencyResponse) -> tuple[Any, FloatArray]:
    if isinstance(response, BestLinearApproximation):
        return response.frf[:, 0, 0], response.band_radius(0.95)[:, 0, 0]
    return response.frf, response.band_radius


def model_response(
    model: Any, omega: FloatArray, *, output: int = 0, input: int = 0, inclination: float | None
) -> Any:
    """The linear model's transfer function ``output <- input`` at ``omega`` rad/s (python-control)."""
    from neckid.export.control import to_control

    scheduled = type(model).__name__ == "GainScheduledModel"
    system = to_control(model, inclination=inclination if scheduled else None)
    response = system.frequency_response(np.asarray(omega, dtype=np.float64), squeeze=False)
    return np.asarray(response.complex)[output, input]


def frequency_fit(
    model: Any,
    data: Any,
    *,
    input_name: str,
    output_name: str,
    multisine: tuple[int, int, int] | None = None,
) -> tuple[FrequencyFit, BestLinearApproximation | FrequencyResponse]:
    """A fitted model's response over the one a log measures (module docstring).

    Parameters
    ----------
    model : fitted neckid model
    data : IOData
        The log, with the model's channels (``read_for_model``).
    input_name, output_name : str
        The excited input and the output compared.
    multisine : (M, P, T), optional
        Realisations, periods and transient periods of a multisine log: the robust BLA is the
        measured response; otherwise the Welch estimate.

    Returns
    -------
    (FrequencyFit, the measured response)
    """
    j, i = data.input_names.index(input_name), data.output_names.index(output_name)
    names = ((input_name,), (output_name,))
    units = ((data.input_units[j],), (data.output_units[i],))
    measured = measured_response(data.u[:, j], data.y[:, i], data.ts, multisine, names, units)
    frf, radius = _pair(measured)
    omega = measured.omega
    model_frf, how = None, ""
    if data.n_inputs == 1:
        try:
            inclination = float(np.mean(data.y[:, i]))
            model_frf = model_response(model, omega, output=i, input=j, inclination=inclination)
            how = "transfer function (to_control)"
        except (TypeError, ValueError):
            model_frf = None  # nonlinear: through its free run below
    if model_frf is None:
        run = model.simulate(data)
        simulated, _ = _pair(measured_response(data.u[:, j], run.y[:, i], data.ts, multisine))
        model_frf, how = simulated, f"{measured.estimate} of its free run on the log's inputs"
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.abs(model_frf - frf) / radius
    finite = np.isfinite(ratio)
    fit = FrequencyFit(
        omega=omega,
        model_frf=model_frf,
        measured_frf=frf,
        band_radius=radius,
        share_inside=float(np.mean(ratio[finite] <= 1.0)) if finite.any() else float("nan"),
        weighted_error=float(np.sqrt(np.mean(ratio[finite] ** 2))) if finite.any() else np.nan,
        model_estimate=how,
        measured_estimate=measured.estimate,
    )
    return fit, measured
