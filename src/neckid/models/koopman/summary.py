"""The Koopman model described for export (JSON, MATLAB): its lifted system and dictionary."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["describe_koopman"]


def describe_koopman(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted KoopmanEDMD (its registry entry's describer).

    Everything a user needs to run the lifted system elsewhere: the matrices (the logs' input
    and output units), the state's names, and the lift (the standardisation of the delays and
    the observables of the standardised lag terms ``r``).
    """
    terms = [int(k) for k in _term_positions(model)]
    return "koopman_edmd", {
        "equation": "z(t+1) = A z(t) + B u(t); y(t) = C z(t) + D u(t); z = [p; phi(r); 1] with"
        " p_j = (s_j(t - lag_j) - mean_j) / std_j the delays (states; mean, std of channel s_j:"
        " input_mean / input_std, output_mean / output_std), r = p[terms]; phi_k ="
        " (g_k(r) - observable_mean_k) / observable_std_k, g_k = d^2 log d (thin-plate),"
        " exp(-d^2 / (2 width^2)) (gaussian), d = |r - centres_k|, or prod_i r_i^powers(k, i)"
        " (monomials); a free run lifts z once from the first max_lag samples",
        "dictionary": str(model.dictionary),
        "n_observables": int(model.n_observables_),
        "ridge": float(model.ridge_),
        "spectral_radius": float(model.spectral_radius_),
        "states": model.state_names(),
        "terms": np.array(terms, dtype=np.int64),
        "A": np.array(model.A_, dtype=np.float64),
        "B": np.array(model.B_, dtype=np.float64),
        "C": np.array(model.C_, dtype=np.float64),
        "D": np.array(model.D_, dtype=np.float64),
        "centres": np.array(model.centres_, dtype=np.float64),
        "powers": np.array(model.powers_, dtype=np.int64),
        "width": float(model.width_),
        "observable_mean": np.array(model.observable_mean_, dtype=np.float64),
        "observable_std": np.array(model.observable_std_, dtype=np.float64),
        "output_mean": np.array(model.y_mean_, dtype=np.float64),
        "output_std": np.array(model.y_std_, dtype=np.float64),
        "input_mean": np.array(model.u_mean_, dtype=np.float64),
        "input_std": np.array(model.u_std_, dtype=np.float64),
        "selection": _ascii(model.selection_["explanation"]) if model.selection_ else "",
    }


def _ascii(text: str) -> str:
    """``text`` in ASCII (a MATLAB .mat file reads other text cut short): ± as +/-."""
    return text.replace("±", "+/-").encode("ascii", "replace").decode("ascii")


def _term_positions(model: Any) -> Any:
    from neckid.models.koopman.lift import Layout

    return Layout.of(model.lags_).terms
