"""What a band bounds, and under which assumption: one name per kind, one sentence per name.

Every :class:`~neckid.models.base.ModelResult` with ``lower`` / ``upper`` says which kind they are
in ``extras["band"]``; :func:`band_meaning` gives the sentence that the CLI, the plots and the
report print beside its width and coverage. Only the kinds marked *guaranteed* bound anything
for sure, and only while the prior holds: a log that falls outside them contradicts the prior
(see ``SetMembership.invalidation``).

============  =====================================================================================
kind          meaning
============  =====================================================================================
sm-one-step   SM one step ahead: bounds f(w) at the measured regressor under the prior (ε, γ)
sm-free-run   SM free run: bounds f at the *simulated* regressor; not a bound on the trajectory
guaranteed    SM k steps ahead: bounds y(t+k) under the prior of horizon k (ε_k, γ_k)
chained       SM k-step blocks re-anchored on the model's own outputs: guaranteed in the first block
calibrated    conformal: covers the measurement with the nominal probability, marginally over samples
adaptive      adaptive conformal: the running share inside tends to the nominal level, shift or not
============  =====================================================================================

References
----------
M. Milanese and C. Novara, "Set Membership identification of nonlinear systems", Automatica
40(6), 957-975, 2004. V. Vovk, A. Gammerman and G. Shafer, *Algorithmic Learning in a Random
World*, Springer, 2005.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["BAND_KINDS", "BAND_LABELS", "GUARANTEED_KINDS", "band_label", "band_meaning"]

#: Each kind of band and what it bounds.
BAND_KINDS: Mapping[str, str] = {
    "sm-one-step": (
        "SM one-step band: bounds the noise-free output f(w) at the measured regressor, under"
        " the prior (noise bound ε, Lipschitz constant γ); a measurement may lie ε beyond it"
    ),
    "sm-free-run": (
        "SM free-run band: bounds f at the simulated regressor, not the trajectory; it is no"
        " guarantee on the run and may hold few of the measured samples"
    ),
    "guaranteed": (
        "SM k-step band: bounds the measured y(t+k) under the prior of horizon k (ε_k, γ_k);"
        " samples outside it contradict that prior"
    ),
    "chained": (
        "SM k-step blocks chained on the model's own outputs: guaranteed in the first block only"
    ),
    "calibrated": (
        "conformal band: covers the measurement with its nominal probability, marginally over"
        " samples, if the new data are exchangeable with the calibration data"
    ),
    "adaptive": (
        "adaptive conformal band: its level is steered by its own misses as the log is read, so"
        " the running share of samples inside tends to the nominal coverage even when the run"
        " changes (no per-sample probability)"
    ),
}

#: Short legend labels of each kind (plots).
BAND_LABELS: Mapping[str, str] = {
    "sm-one-step": "SM bound of f, one step",
    "sm-free-run": "SM bound of f at the simulated regressor (not of the run)",
    "guaranteed": "SM k-step band (guaranteed under its prior)",
    "chained": "SM chained k-step band",
    "calibrated": "conformal band",
    "adaptive": "adaptive conformal band",
}

#: The kinds that bound something for sure while their prior holds.
GUARANTEED_KINDS = frozenset({"sm-one-step", "guaranteed"})


def band_meaning(extras: Mapping[str, Any]) -> str:
    """The sentence for a result's ``extras["band"]`` (with its coverage for a calibrated one).

    Examples
    --------
    >>> band_meaning({"band": "sm-free-run"}).split(":")[0]
    'SM free-run band'
    >>> band_meaning({"band": "calibrated", "coverage": 0.9}).startswith("conformal band (90 %")
    True
    >>> band_meaning({})
    'band of an unknown kind (no claim on what it bounds)'
    """
    kind = str(extras.get("band", ""))
    if kind not in BAND_KINDS:
        return "band of an unknown kind (no claim on what it bounds)"
    text = BAND_KINDS[kind]
    if kind in ("calibrated", "adaptive") and "coverage" in extras:
        percent = round(100 * float(extras["coverage"]))
        text = text.replace("conformal band:", f"conformal band ({percent} % nominal):", 1)
    return text


def band_label(extras: Mapping[str, Any]) -> str:
    """A short legend label for a result's band (``"band"`` when its kind is unknown).

    Examples
    --------
    >>> band_label({"band": "calibrated", "coverage": 0.95})
    'conformal band, 95 % nominal'
    """
    kind = str(extras.get("band", ""))
    label = BAND_LABELS.get(kind, "band")
    if kind in ("calibrated", "adaptive") and "coverage" in extras:
        label += f", {round(100 * float(extras['coverage']))} % nominal"
    return label
