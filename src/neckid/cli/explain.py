"""What a free run means, said under its table: the prior, the band, the domain, extrapolation.

Helpers of ``neckid validate`` and ``neckid simulate`` (:mod:`neckid.cli.models`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from rich.markup import escape

from neckid.cli._app import _metrics_table, console, error_console


def _describe_model(model: Any) -> str:
    """The label of the model's method (``Set Membership + linear``), or its class name."""
    from neckid.registry import method_of

    method = method_of(model)
    return method.label if method is not None else type(model).__name__


def _print_prior(model: Any) -> None:
    """ε and γ of a Set Membership model (or of the SM map of a parallel one), with units."""
    prior = model.set_membership_prior()
    if prior is None or prior.horizons is not None:
        return  # a model with one prior per horizon describes itself (neckid info)
    for name, unit, epsilon, gamma in zip(
        model.output_names_, model.output_units_, prior.epsilon, prior.gamma, strict=True
    ):
        shown = f" {unit}" if unit else ""
        console.print(
            f"Set Membership prior for {name}: noise bound ε = {epsilon:.4g}{shown}, Lipschitz"
            f" constant γ = {gamma:.4g}{shown} per unit of the scaled regressor"
        )


def _print_band(result: Any, data: Any) -> None:
    """Mean width and coverage of a result's band, and which kind of band it is."""
    if result.lower is None or result.upper is None:
        return
    from neckid.metrics import coverage, mean_width
    from neckid.models.bands import band_meaning

    kind = band_meaning(result.extras)
    skip = result.n_initial
    widths = mean_width(result.lower, result.upper, skip=skip)
    covered = coverage(data.y, result.lower, result.upper, skip=skip)
    for j, name in enumerate(data.output_names):
        unit = f" {data.output_units[j]}" if data.output_units[j] else ""
        console.print(
            f"band of {name}: mean width {widths[j]:.4g}{unit}, holds {covered[j]:.1%} of the"
            f" measured samples. {kind}",
            markup=False,
        )


def _print_horizons(model: Any, data: Any) -> None:
    """For a multi-step SM model: the guaranteed k-step band on the log, per named horizon.

    The horizons shown are 1, the block ``horizon`` and the extra ``horizons``; for each, the
    band of ``predict_ahead`` (its mean width and the share of the measured samples it holds),
    ε_k, and the smallest ε_k that would hold every sample (γ_k kept).
    """
    prior = model.set_membership_prior()
    if prior is None or prior.horizons is None:
        return
    from neckid.metrics import coverage, mean_width

    named = sorted({1, int(model.horizon), *(int(k) for k in model.horizons or ())})
    rows: list[dict[str, Any]] = []
    for k in named:
        i = model.horizons_.tolist().index(k)
        predictor = model.estimators_[i]  # only the named horizons, not all of invalidation()'s
        if data.n_samples <= predictor.lags_.max_lag:
            continue
        ahead = model.predict_ahead(data, steps=k)
        skip = ahead.n_initial
        widths = mean_width(ahead.lower, ahead.upper, skip=skip)
        held = coverage(data.y, ahead.lower, ahead.upper, skip=skip)
        needed = predictor.invalidation(data).smallest_epsilon
        for j, name in enumerate(data.output_names):
            unit = data.output_units[j] or "-"
            rows.append(
                {
                    "k [samples]": str(k),
                    "k [s]": f"{k * data.ts:.3g}",
                    "output": name,
                    f"mean width [{unit}]": float(widths[j]),
                    "holds [%]": float(100 * held[j]),
                    f"eps_k [{unit}]": float(model.epsilon_[i, j]),
                    f"eps_k to hold all, gamma kept [{unit}]": float(needed[j]),
                }
            )
    if rows:
        console.print(
            _metrics_table("guaranteed k-step bands (predicted k samples ahead from the log)", rows)
        )
    _print_horizon_settings(model, named)


def _print_horizon_settings(model: Any, named: list[int]) -> None:
    """Each named horizon's ε factor, input weight and constants, and whether they were chosen."""
    settings = model.settings_
    if not settings:
        return
    how = (
        f"chosen by held-out coverage ≥ {float(model.target_coverage):.0%} on the training logs"
        if model.selection_ is not None
        else "as given"
    )
    for k in named:
        setting = settings[model.horizons_.tolist().index(k)]
        factor = (
            "ε given" if setting.epsilon_factor is None else f"ε factor {setting.epsilon_factor:g}"
        )
        console.print(
            f"k = {k}: {factor}, input weight {setting.input_weight:g}, {setting.lipschitz}"
            f" Lipschitz constants ({how})",
            markup=False,
        )


def _print_prior_check(model: Any, data: Any) -> None:
    """For an SM model: does the log contradict its prior, one step ahead? And what to do."""
    prior = model.set_membership_prior()
    if prior is None or prior.horizons is not None:
        return
    epsilon = prior.epsilon
    found = model.invalidation(data)
    for j, name in enumerate(data.output_names):
        unit = f" {data.output_units[j]}" if data.output_units[j] else ""
        share = float(found.fraction[j])
        if share == 0:
            console.print(
                f"prior check of {name} (one step ahead, measured regressors): every sample lies"
                f" in [f_l − ε, f_u + ε] (ε = {float(epsilon[j]):.4g}{unit}); the log does not"
                " contradict the prior",
                markup=False,
            )
            continue
        advice = (
            f"{_share_text(share)} of the samples of {name} fall outside [f_l − ε, f_u + ε] one step"
            f" ahead (ε = {float(epsilon[j]):.4g}{unit}, γ kept): the SM bounds are not"
            " guaranteed on this log. The smallest ε that holds them all is"
            f" {float(found.smallest_epsilon[j]):.4g}{unit}. Identify again with this log among"
            " the training logs, or with a larger --set epsilon=..., or update the model with"
            " it (SetMembership.partial_fit in Python)."
        )
        error_console.print(
            f"[yellow]prior contradicted:[/yellow] {escape(advice)}",
            highlight=False,
            soft_wrap=True,
        )


def _print_domain(model: Any, data: Any) -> Any:
    """The share of the log outside the model's domain (regressor box, SM nearest regressor)."""
    if not model.regressor_box() or data.n_samples <= model.max_lag_:
        return None
    domain = model.domain(data)
    worst = sorted(domain.by_term.items(), key=lambda kv: -kv[1])[:3]
    terms = ", ".join(f"{k} {v:.0%}" for k, v in worst if v > 0) or "none"
    text = (
        f"domain: {domain.share:.1%} of the samples lie outside the regressors the model was"
        f" identified on (terms outside their training range: {terms}"
    )
    if domain.radius is not None and domain.distance is not None:
        far = float(np.nanmean(domain.distance[domain.n_initial :] > domain.radius))
        text += (
            f"; {far:.1%} farther from every training regressor than"
            f" {domain.radius:.3g} (the 99th percentile of the training regressors' own"
            " nearest-neighbour distances, scaled space)"
        )
    console.print(text + ")", markup=False)
    return domain


def _report_extrapolation(result: Any) -> None:
    from neckid.models.base import EXTRAPOLATION_WARNING

    shares = result.extras.get("extrapolation", {})
    far = {k: v for k, v in shares.items() if v > EXTRAPOLATION_WARNING}
    if far:
        error_console.print(
            "[yellow]warning:[/yellow] the log leaves the range the model was identified on: "
            + ", ".join(f"{k} {v:.0%} of the samples" for k, v in far.items())
            + "; expect a poor fit there",
            highlight=False,
            soft_wrap=True,
        )


def _save_panels(panels: list[tuple[Any, dict[str, Any], str, Any]], path: Any) -> None:
    """One panel per log, stacked: ``(log data, {label: run}, title, samples outside or None)``.

    Each panel holds one axes per output of its log (:func:`neckid.report.plots.plot_outputs`):
    a two-output model shows both outputs of every log, each with its band and unit.
    """
    import matplotlib.pyplot as plt

    from neckid.report.plots import plot_outputs

    rows = sum(data.n_outputs for data, _, _, _ in panels)
    fig, axes = plt.subplots(rows, 1, figsize=(10, 3.4 * rows), layout="constrained", squeeze=False)
    first = 0
    for data, runs, title, outside in panels:
        mine = list(axes[first : first + data.n_outputs, 0])
        plot_outputs(data, runs, mine, title=title, outside=outside)
        first += data.n_outputs
    _save_figure(fig, path)


def _save_figure(fig: Any, path: Any) -> None:
    """Write ``fig`` as PNG (atomically: a failed write leaves no half file) and close it."""
    import matplotlib.pyplot as plt

    from neckid.utils.files import atomic_path

    try:
        with atomic_path(path) as temporary:
            fig.savefig(temporary, dpi=120, format="png")
    finally:
        plt.close(fig)


def _share_text(share: float) -> str:
    """A share as a percentage that never rounds a non-zero share to 0.0 % (nor a partial to 100 %)."""
    if 0.0 < share < 0.0005:
        return "fewer than 0.1 %"
    if 0.9995 < share < 1.0:
        return "more than 99.9 %"
    return f"{share:.1%}"
