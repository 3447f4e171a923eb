"""The one registry of identification methods: a name, a label, and a factory of unfitted estimators.

The command line, :func:`~neckid.select_lags`, the benchmark, the demo and the contract test all
find methods here, by one spelling. A new model is added by registering it in :data:`_METHODS`
(and nowhere else): the contract test then runs over it, ``neckid identify --method`` offers it,
and ``neckid.load_model`` reads its files (model classes are found through this table, see
:func:`model_classes`).

Examples
--------
>>> import neckid
>>> sorted(neckid.methods())
['arx', 'greybox-neck', 'greybox-tanks', 'lpv', 'nn', 'pnlss', 'poly', 'rls', 'scheduled',
 'scheduled-position', 'sm', 'sm-linear', 'sm-multistep', 'sm-parallel', 'sm-parallel-poly', 'ss']
>>> model = neckid.methods()["sm-linear"].make(neckid.Lags.arx(2, 2))
>>> type(model).__name__, model.linear_part
('SetMembership', True)
"""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from neckid.regressors import Lags

__all__ = ["DEPRECATED_NAMES", "Method", "get_method", "method_of", "methods", "model_classes"]


@dataclass(frozen=True)
class Method:
    """One identification method of the registry.

    Attributes
    ----------
    name : str
        The one spelling used everywhere (``"sm-linear"``).
    label : str
        How tables and figures name it (``"Set Membership + linear part"``).
    estimator : str
        ``"module:Class"`` of the estimator class.
    defaults : mapping
        Hyper-parameters that make this method out of its class (``{"linear_part": True}``);
        :meth:`make` applies them before the caller's.
    quick : mapping
        Settings for a fast smoke run (tests, ``--quick``): fewer iterations, smaller networks.
    summary : str
        One line for ``--help`` and the README.
    """

    name: str
    label: str
    estimator: str
    summary: str
    defaults: Mapping[str, Any] = field(default_factory=dict)
    quick: Mapping[str, Any] = field(default_factory=dict)

    def estimator_class(self) -> type[Any]:
        """The estimator class (its module is imported on first use)."""
        module, _, name = self.estimator.partition(":")
        cls: type[Any] = getattr(importlib.import_module(module), name)
        return cls

    def make(self, lags: Lags | None = None, *, quick: bool = False, **params: Any) -> Any:
        """An unfitted estimator of this method with regressor ``lags``.

        Parameters
        ----------
        lags : Lags, optional
            The regressor (for ``sm-parallel``: its linear model's; for ``scheduled`` and
            ``scheduled-position``: ``Lags.arx(1, 1, d)``, or ``None``: ``d = 1`` on the data's
            one input). ``None`` leaves it to be set later with ``set_params`` (the scheduled
            model fits with its default).
        quick : bool, default False
            Apply :attr:`quick` (smoke-run settings) before ``params``.
        **params
            Any other hyper-parameter of the class, keyword-only.
        """
        settings = {**self.defaults, **(self.quick if quick else {}), **params}
        return self.estimator_class()(lags, **settings)

    __call__ = make


_METHODS: tuple[Method, ...] = (
    Method(
        "arx",
        "Linear ARX",
        "neckid.models.linear.arx:LinearARX",
        "linear ARX by batch least squares",
    ),
    Method(
        "rls",
        "CFF-RLS ARX",
        "neckid.models.linear.rls:RecursiveARX",
        "ARX by recursive least squares with a constant forgetting factor (0.98)",
    ),
    Method(
        "ss",
        "State space (subspace)",
        "neckid.models.linear.subspace:SubspaceStateSpace",
        "linear state-space model by subspace identification (PO-MOESP), order from the singular"
        " values, refined on the free-run error, stable",
        quick={"max_iter": 20},
    ),
    Method(
        "pnlss",
        "Polynomial state space (PNLSS)",
        "neckid.models.pnlss.model:PolynomialStateSpace",
        "polynomial nonlinear state-space model of degree 3 (Paduart et al. 2010): the ss model"
        " plus monomials of states and inputs, fitted on the free-run error",
        quick={"degree": 2, "max_iter": 10},
    ),
    Method(
        "sm",
        "Set Membership",
        "neckid.models.set_membership.narx:SetMembership",
        "Set Membership NARX (Milanese & Novara 2004), bounds and central estimate",
    ),
    Method(
        "sm-linear",
        "Set Membership + linear",
        "neckid.models.set_membership.narx:SetMembership",
        "Set Membership on the residual of a linear ARX part",
        defaults={"linear_part": True},
    ),
    Method(
        "sm-parallel",
        "Set Membership parallel",
        "neckid.models.set_membership.parallel:ParallelSetMembership",
        "Set Membership on the free run of a parallel linear ARX (output-error form)",
    ),
    Method(
        "sm-parallel-poly",
        "Set Membership parallel (polynomial OE)",
        "neckid.models.set_membership.parallel:ParallelSetMembership",
        "Set Membership on the free run of a parallel degree-3 polynomial NARX fitted for"
        " simulation",
        defaults={"parallel_degree": 3, "parallel_fit": "simulation"},
        quick={"parallel_degree": 2},
    ),
    Method(
        "poly",
        "Polynomial NARX (OE)",
        "neckid.models.polynomial.narx:PolynomialNARX",
        "polynomial NARX of degree 3, least squares then fitted for free-run simulation",
        quick={"degree": 2, "max_iter": 10},
    ),
    Method(
        "lpv",
        "LPV-ARX",
        "neckid.models.lpv.model:LPVARX",
        "linear parameter-varying ARX: coefficients polynomial (degree 2) in a condition (the"
        " payload) or a measured channel (the inclination), least squares then fitted for"
        " free-run simulation, stable at every frozen scheduling value",
        quick={"max_iter": 10},
    ),
    Method(
        "nn",
        "Neural NARX 2x25",
        "neckid.models.neural.narx:NeuralNARX",
        "neural-network NARX, 2 hidden layers of 25 (tanh), mean of 5 networks",
        defaults={"random_state": 0},
        quick={"hidden_layer_sizes": (8,), "max_iter": 50, "n_networks": 2},
    ),
    Method(
        "scheduled",
        "Scheduled CFF-RLS",
        "neckid.models.scheduled.model:GainScheduledModel",
        "the seed paper's first-order model N(i)/(z - P(i)) from velocity command to inclination"
        " rate, scheduled on the inclination; operating points by CFF-RLS where it dwells",
    ),
    Method(
        "scheduled-position",
        "Scheduled CFF-RLS (position form)",
        "neckid.models.scheduled.model:GainScheduledModel",
        "the scheduled first-order model from motor position to inclination (no integrator: use"
        " it for free runs); operating points by CFF-RLS where the inclination dwells",
        defaults={"form": "position"},
    ),
    Method(
        "greybox-neck",
        "Grey-box neck (slack + hysteresis)",
        "neckid.models.greybox.model:GreyBoxNeck",
        "tendon slack and a Prandtl-Ishlinskii hysteresis in series with stable second-order"
        " dynamics, fitted on the free-run error",
        quick={"max_iter": 8, "n_play": 2},
    ),
    Method(
        "greybox-tanks",
        "Grey-box cascaded tanks (ODE)",
        "neckid.models.greybox.ode:GreyBoxODE",
        "the cascaded tanks' physical model (power-law outflows from Torricelli's, pump dead zone, both"
        " tanks' overflows; one pump voltage in, one level out), parameters fitted on the"
        " free-run error; GreyBoxODE takes a user's structure the same way",
        defaults={"structure": "cascaded-tanks"},
        quick={"n_starts": 2, "max_iter": 20},
    ),
    Method(
        "sm-multistep",
        "Multi-step Set Membership",
        "neckid.models.set_membership.multistep:MultiStepSetMembership",
        "direct k-step Set Membership predictors (1..horizon) with guaranteed k-step bands",
        quick={"horizon": 3},
    ),
)

#: Spellings of earlier releases, accepted by the command line with a deprecation message.
DEPRECATED_NAMES: Mapping[str, str] = MappingProxyType(
    {"sm_linear": "sm-linear", "sm_parallel": "sm-parallel", "neural": "nn"}
)

_BY_NAME = MappingProxyType({m.name: m for m in _METHODS})


def methods() -> Mapping[str, Method]:
    """The registered methods, by name, in a fixed order (read-only mapping)."""
    return _BY_NAME


def get_method(name: str, *, allow_deprecated: bool = True) -> Method:
    """The method called ``name``; a deprecated spelling warns (``FutureWarning``) and maps over.

    Raises
    ------
    ValueError
        If no method has that name (the message lists the names).
    """
    if allow_deprecated and name in DEPRECATED_NAMES:
        new = DEPRECATED_NAMES[name]
        warnings.warn(
            f"method name {name!r} is deprecated and will be removed in the next release;"
            f" use {new!r}",
            FutureWarning,
            stacklevel=2,
        )
        name = new
    if name not in _BY_NAME:
        raise ValueError(f"method must be one of {list(_BY_NAME)}; got {name!r}")
    return _BY_NAME[name]


def method_of(model: Any) -> Method | None:
    """The registered method an estimator belongs to (its class and the method's defaults).

    Examples
    --------
    >>> from neckid import Lags, SetMembership
    >>> method_of(SetMembership(Lags.arx(1, 1), linear_part=True)).name
    'sm-linear'
    """
    params = model.get_params(deep=False) if hasattr(model, "get_params") else {}
    candidates = [
        m
        for m in _METHODS
        if m.estimator.partition(":")[2] == type(model).__name__
        and all(params.get(k) == v for k, v in m.defaults.items() if k != "random_state")
    ]
    # The method with the most defaults matched is the most specific (sm-linear before sm).
    return max(candidates, key=lambda m: len(m.defaults), default=None)


def model_classes() -> Mapping[str, str]:
    """Model-file class name -> module, for :func:`neckid.load_model` (derived from the methods)."""
    classes: dict[str, str] = {}
    for method in _METHODS:
        module, _, name = method.estimator.partition(":")
        classes[name] = module
    return MappingProxyType(classes)
