"""What a fitted model tells about itself: the part of the estimator contract that describes it.

The command line (``neckid info``, ``validate``), the export and the design read a model through
these methods and attributes only, never by probing its internals (``getattr(model, "sm_",
model)``): every estimator has them (:class:`~neckid.models.base.Estimator` inherits
:class:`ModelFacts`), and a family that has something to tell overrides the method that tells it.

- :attr:`ModelFacts.preprocessing_` and :attr:`ModelFacts.channel_map_`: the preprocessing and
  the log-to-model channel names the model was identified with (``None`` for none);
- :meth:`ModelFacts.fitted_lags`: the resolved regressor (``None`` for a model whose regressor is
  not a set of lags: state-space, grey-box and scheduled models), and
  :meth:`ModelFacts.condition_names`, the conditions it takes as inputs;
- :meth:`ModelFacts.training_box` and :meth:`ModelFacts.regressor_box`: the channels' and the
  regressor terms' training ranges;
- :meth:`ModelFacts.training_samples`: how many samples (or regressor rows) it was fitted on;
- :meth:`ModelFacts.set_membership_prior`: the noise bound ε and the Lipschitz constant γ of a
  Set Membership model (or of the SM map of a parallel one), ``None`` for the others;
- :meth:`ModelFacts.state_order`: the order of a subspace-started state-space model and the
  singular values it was chosen from, ``None`` for the others;
- :meth:`ModelFacts.schedule_summary`: the schedule of a scheduled or LPV model in numbers and
  words, empty for the others.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from neckid.utils.types import FloatArray

if TYPE_CHECKING:
    from neckid.data.preprocess import Pipeline
    from neckid.regressors import ResolvedLags

__all__ = ["ModelFacts", "SetMembershipPrior", "StateOrder"]


@dataclass(frozen=True)
class SetMembershipPrior:
    """The prior of a Set Membership model: what ``neckid info`` and ``validate`` show.

    Attributes
    ----------
    epsilon, gamma : ndarray, shape (n_outputs,) or (n_horizons, n_outputs)
        Noise bound ε and Lipschitz constant γ per output (per horizon of a multi-step model),
        in the output units (γ per unit of the scaled regressor).
    horizons : tuple of int or None
        The horizons of a multi-step model (one row of ``epsilon`` and ``gamma`` each); ``None``
        for a one-step model.
    lipschitz : str
        ``"global"`` (one γ) or ``"local"`` (one constant per training point).
    distance : str
        The scaling of the distance (``"std"``, ``"gradient"``, ``"none"``), or ``"user
        weights"``.
    estimate : str or None
        What a parallel model's point estimate is (``"central"``, ``"projection"``); ``None``
        for a model without that choice.
    """

    epsilon: FloatArray
    gamma: FloatArray
    horizons: tuple[int, ...] | None
    lipschitz: str
    distance: str
    estimate: str | None = None

    @staticmethod
    def distance_of(scaling: object) -> str:
        """The name of a ``scaling`` hyper-parameter (``"user weights"`` for an array)."""
        return scaling if isinstance(scaling, str) else "user weights"


@dataclass(frozen=True)
class StateOrder:
    """The order of a state-space model and the singular values of the subspace step it came from.

    Attributes
    ----------
    order : int
        The state dimension.
    singular_values : ndarray
        The singular values the order was read from (largest first).
    """

    order: int
    singular_values: FloatArray


class ModelFacts:
    """The descriptive part of the estimator contract (see the module docstring).

    Attributes
    ----------
    preprocessing_ : Pipeline or None
        The steps the training data went through before ``fit`` (set by whoever fitted the
        model on preprocessed data, kept in its file); a log must go through them before
        ``simulate``. ``None`` (the class default): none.
    channel_map_ : mapping of str to str or None
        Log channel name -> model channel name, as the model was identified (the CLI's
        ``--map``, kept in its file and replayed on the logs it reads). ``None``: none.
    """

    preprocessing_: Pipeline | None = None
    channel_map_: Mapping[str, str] | None = None

    def fitted_lags(self) -> ResolvedLags | None:
        """The resolved regressor of a fitted NARX model (``lags_``); ``None`` for the others."""
        lags: ResolvedLags | None = getattr(self, "lags_", None)
        return lags

    def condition_names(self) -> tuple[str, ...]:
        """The conditions the model takes as inputs: its resolved lags', else its ``lags``'."""
        names = getattr(getattr(self, "lags_", None), "conditions", None)
        if names is None:
            names = getattr(getattr(self, "lags", None), "conditions", None)
        return tuple(names or ())

    def training_box(self) -> dict[str, tuple[float, float]]:
        """``{channel: (low, high)}`` over the training data (empty before ``fit``)."""
        return dict(getattr(self, "training_ranges_", {}) or {})

    def regressor_box(self) -> dict[str, tuple[float, float]]:
        """``{regressor term: (low, high)}`` over the training rows; empty without a regressor."""
        return dict(getattr(self, "regressor_ranges_", {}) or {})

    def training_samples(self) -> int | None:
        """How many samples (NARX models: regressor rows) the model was fitted on, if recorded."""
        n = getattr(self, "n_samples_", None)
        return None if n is None else int(n)

    def set_membership_prior(self) -> SetMembershipPrior | None:
        """The Set Membership prior (ε, γ and how distances are measured); ``None`` here."""
        return None

    def state_order(self) -> StateOrder | None:
        """The state order and the singular values it was chosen from; ``None`` here."""
        return None

    def schedule_summary(self) -> dict[str, Any]:
        """The schedule, keyed as ``neckid info`` shows it (``{"schedule": ...}``); empty here."""
        return {}
