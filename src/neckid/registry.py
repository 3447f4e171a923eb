"""The one registry of identification methods: a name, a label, a factory, and the facts about it.

The command line, :func:`~neckid.select_lags`, the benchmark, the demo and the contract test all
find methods here, by one spelling. A new model is added by registering it in :data:`_METHODS`
(and nowhere else, but for its benchmark grid): the contract test then runs over it, ``neckid
identify --method`` offers it, and ``neckid.load_model`` reads its files (model classes are found
through this table, see :func:`model_classes`). What the rest of the package needs to know about
a method is a field of its :class:`Method`: how simple it is (the one-standard-error rule of
:mod:`neckid.selection.comparison`), whether its regressor is its lags, what it builds on and
where it runs in the benchmark, what a benchmark unit of it costs, which function describes it
for export, and which python-control form :func:`neckid.export.control.to_control` gives by
default. The registry imports nothing but :mod:`neckid.regressors`: the export describer is a
``"module:function"`` text, resolved by :mod:`neckid.export.describe` when it describes a model,
and the benchmark's data-set groups are names the benchmark resolves.

Examples
--------
>>> import neckid
>>> sorted(neckid.methods())
['arx', 'greybox-neck', 'greybox-tanks', 'koopman', 'lpv', 'nn', 'pnlss', 'poly', 'rls',
 'scheduled', 'scheduled-position', 'sindy', 'sm', 'sm-linear', 'sm-multistep', 'sm-parallel',
 'sm-parallel-koopman', 'sm-parallel-poly', 'sm-parallel-sindy', 'ss']
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
    complexity : int, default 99
        How simple the method is, for the one-standard-error rule of
        :func:`neckid.selection.comparison.select_safely` (smaller is simpler; linear ARX is 0).
    lag_free : bool, default False
        Whether the regressor is not its lags (the state-space and grey-box models: their order
        comes from the data or the structure): one candidate each, not one per lag set.
    builds_on : str, optional
        The method whose chosen lags this one's benchmark lag grid is cut to (``sm-parallel-poly``
        sits on the polynomial ``poly``'s own selection picked).
    only_on : {"public", "softneck"}, optional
        The benchmark's data-set group the method runs on (``None``: every data set); the
        benchmark resolves the name (:data:`neckid.experiments.benchmark.settings.ONLY_ON`).
    unit_cost : float, default 5.0
        Relative cost of one benchmark unit per training sample: the order in which a stage
        hands its units to the workers (longest first). It changes the wall time only.
    cost : str
        ``"module:function"`` of the expected cost of one selection unit of this method, from
        the estimator's own settings and the data's size: ``function(estimator, n_samples,
        n_terms) -> float`` (:mod:`neckid.selection.costs`), in :attr:`unit_cost` × samples'
        unit; the time left of a selection's progress (:func:`neckid.selection.work.unit_cost`).
        Empty: :attr:`unit_cost` × samples.
    benchmark_params : mapping
        Hyper-parameters beside :attr:`defaults` of the benchmark's one candidate of a state
        model (empty for every method today).
    describer : str
        ``"module:function"`` describing a fitted model of this method for
        :func:`neckid.export.export_model`: ``function(model) -> (structure, parameters)``.
    control_form : {"tf", "ss"}, default "tf"
        The form :func:`neckid.export.control.to_control` gives by default: ``"ss"`` for the
        state-space models (a MIMO ``StateSpace`` needs no slycot), ``"tf"`` for the ARX models.
    c_export : str
        ``"module:function"`` writing a fitted model of this method as C for
        :func:`neckid.export.c.c_model`: ``function(model) -> CModel`` (empty: the method has
        no C export, and ``neckid export --to c`` says so).
    """

    name: str
    label: str
    estimator: str
    summary: str
    defaults: Mapping[str, Any] = field(default_factory=dict)
    quick: Mapping[str, Any] = field(default_factory=dict)
    complexity: int = 99
    lag_free: bool = False
    builds_on: str | None = None
    only_on: str | None = None
    unit_cost: float = 5.0
    cost: str = ""
    benchmark_params: Mapping[str, Any] = field(default_factory=dict)
    describer: str = ""
    control_form: str = "tf"
    c_export: str = ""

    @property
    def class_name(self) -> str:
        """The estimator's class name (``"SetMembership"``)."""
        return self.estimator.partition(":")[2]

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
        complexity=0,
        unit_cost=0.01,
        describer="neckid.export.describe:describe_arx",
        cost="neckid.selection.costs:arx_cost",
        c_export="neckid.export.c.narx:c_arx",
    ),
    Method(
        "rls",
        "CFF-RLS ARX",
        "neckid.models.linear.rls:RecursiveARX",
        "ARX by recursive least squares with a constant forgetting factor (0.98)",
        complexity=1,
        describer="neckid.export.describe:describe_rls",
        c_export="neckid.export.c.narx:c_rls",
    ),
    Method(
        "ss",
        "State space (subspace)",
        "neckid.models.linear.subspace:SubspaceStateSpace",
        "linear state-space model by subspace identification (PO-MOESP), order from the singular"
        " values, refined on the free-run error, stable",
        quick={"max_iter": 20},
        complexity=2,
        lag_free=True,
        unit_cost=0.3,
        describer="neckid.export.describe:describe_subspace",
        cost="neckid.selection.costs:subspace_cost",
        c_export="neckid.export.c.state_space:c_subspace",
        control_form="ss",
    ),
    Method(
        "pnlss",
        "Polynomial state space (PNLSS)",
        "neckid.models.pnlss.model:PolynomialStateSpace",
        "polynomial nonlinear state-space model of degree 3 (Paduart et al. 2010): the ss model"
        " plus monomials of states and inputs, fitted on the free-run error",
        quick={"degree": 2, "max_iter": 10},
        complexity=4,
        lag_free=True,
        unit_cost=20.0,
        describer="neckid.export.describe:describe_pnlss",
        cost="neckid.selection.costs:pnlss_cost",
        c_export="neckid.export.c.state_space:c_pnlss",
        control_form="ss",
    ),
    Method(
        "sm",
        "Set Membership",
        "neckid.models.set_membership.narx:SetMembership",
        "Set Membership NARX (Milanese & Novara 2004), bounds and central estimate",
        complexity=3,
        unit_cost=1.0,
        describer="neckid.export.describe:describe_set_membership",
        cost="neckid.selection.costs:set_membership_cost",
        c_export="neckid.export.c.set_membership:c_set_membership",
    ),
    Method(
        "sm-linear",
        "Set Membership + linear",
        "neckid.models.set_membership.narx:SetMembership",
        "Set Membership on the residual of a linear ARX part",
        defaults={"linear_part": True},
        complexity=2,
        unit_cost=1.0,
        describer="neckid.export.describe:describe_set_membership",
        cost="neckid.selection.costs:set_membership_cost",
        c_export="neckid.export.c.set_membership:c_set_membership",
    ),
    Method(
        "sm-parallel",
        "Set Membership parallel",
        "neckid.models.set_membership.parallel:ParallelSetMembership",
        "Set Membership on the free run of a parallel linear ARX (output-error form)",
        complexity=3,
        unit_cost=2.0,
        describer="neckid.export.describe:describe_parallel",
        cost="neckid.selection.costs:parallel_cost",
        c_export="neckid.export.c.parallel:c_parallel",
    ),
    Method(
        "sm-parallel-poly",
        "Set Membership parallel (polynomial OE)",
        "neckid.models.set_membership.parallel:ParallelSetMembership",
        "Set Membership on the free run of a parallel degree-3 polynomial NARX fitted for"
        " simulation",
        defaults={"parallel_degree": 3, "parallel_fit": "simulation"},
        quick={"parallel_degree": 2},
        complexity=5,
        builds_on="poly",
        only_on="public",
        unit_cost=3.0,
        describer="neckid.export.describe:describe_parallel",
        cost="neckid.selection.costs:parallel_cost",
        c_export="neckid.export.c.parallel:c_parallel",
    ),
    Method(
        "poly",
        "Polynomial NARX (OE)",
        "neckid.models.polynomial.narx:PolynomialNARX",
        "polynomial NARX of degree 3, least squares then fitted for free-run simulation",
        quick={"degree": 2, "max_iter": 10},
        complexity=4,
        only_on="public",
        unit_cost=10.0,
        describer="neckid.export.describe:describe_polynomial",
        cost="neckid.selection.costs:polynomial_cost",
        c_export="neckid.export.c.narx:c_polynomial",
    ),
    Method(
        "lpv",
        "LPV-ARX",
        "neckid.models.lpv.model:LPVARX",
        "linear parameter-varying ARX: coefficients polynomial (degree 2) in a condition (the"
        " payload) or a measured channel (the inclination), least squares then fitted for"
        " free-run simulation, stable at every frozen scheduling value",
        quick={"max_iter": 10},
        complexity=3,
        unit_cost=3.0,
        describer="neckid.models.lpv.summary:describe_lpv",
        c_export="neckid.export.c.narx:c_polynomial",
        control_form="ss",
    ),
    Method(
        "nn",
        "Neural NARX 2x25",
        "neckid.models.neural.narx:NeuralNARX",
        "neural-network NARX, 2 hidden layers of 25 (tanh), mean of 5 networks",
        defaults={"random_state": 0},
        quick={"hidden_layer_sizes": (8,), "max_iter": 50, "n_networks": 2},
        complexity=6,
        unit_cost=8.0,
        describer="neckid.export.describe:describe_neural",
        cost="neckid.selection.costs:neural_cost",
        c_export="neckid.export.c.neural:c_neural",
    ),
    Method(
        "scheduled",
        "Scheduled CFF-RLS",
        "neckid.models.scheduled.model:GainScheduledModel",
        "the seed paper's first-order model N(i)/(z - P(i)) from velocity command to inclination"
        " rate, scheduled on the inclination; operating points by CFF-RLS where it dwells",
        complexity=1,
        only_on="softneck",
        unit_cost=0.01,
        describer="neckid.export.describe:describe_scheduled",
        c_export="neckid.export.c.scheduled:c_scheduled",
        control_form="ss",
    ),
    Method(
        "scheduled-position",
        "Scheduled CFF-RLS (position form)",
        "neckid.models.scheduled.model:GainScheduledModel",
        "the scheduled first-order model from motor position to inclination (no integrator: use"
        " it for free runs); operating points by CFF-RLS where the inclination dwells",
        defaults={"form": "position"},
        describer="neckid.export.describe:describe_scheduled",
        c_export="neckid.export.c.scheduled:c_scheduled",
        control_form="ss",
    ),
    Method(
        "greybox-neck",
        "Grey-box neck (slack + hysteresis)",
        "neckid.models.greybox.model:GreyBoxNeck",
        "tendon slack and a Prandtl-Ishlinskii hysteresis in series with stable second-order"
        " dynamics, fitted on the free-run error",
        quick={"max_iter": 8, "n_play": 2},
        complexity=2,
        lag_free=True,
        only_on="softneck",
        unit_cost=1.0,
        describer="neckid.export.describe:describe_greybox",
        c_export="neckid.export.c.greybox:c_greybox",
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
        complexity=2,
        lag_free=True,
        describer="neckid.export.describe:describe_greybox_ode",
    ),
    Method(
        "sm-multistep",
        "Multi-step Set Membership",
        "neckid.models.set_membership.multistep:MultiStepSetMembership",
        "direct k-step Set Membership predictors (1..horizon) with guaranteed k-step bands",
        quick={"horizon": 3},
        complexity=4,
        describer="neckid.export.describe:describe_multistep",
        cost="neckid.selection.costs:multistep_cost",
        c_export="neckid.export.c.multistep:c_multistep",
    ),
    Method(
        "sindy",
        "Sparse NARX (SINDy)",
        "neckid.models.sindy.model:SparseNARX",
        "sparse identification with control in discrete time (SINDYc): STLSQ over monomials of"
        " degree 3, threshold by the selection rule, then fitted for free-run simulation",
        quick={"degree": 2, "max_iter": 20, "thresholds": (0.1, 0.01)},
        complexity=3,
        unit_cost=2.0,
        describer="neckid.models.sindy.summary:describe_sindy",
        cost="neckid.selection.costs:sindy_cost",
        c_export="neckid.export.c.sindy:c_sindy",
    ),
    Method(
        "sm-parallel-sindy",
        "Set Membership parallel (sparse NARX)",
        "neckid.models.set_membership.parallel:ParallelSetMembership",
        "Set Membership on the free run of a parallel sparse NARX (sindy): guaranteed one-step"
        " bounds around the sparse simulator",
        defaults={"base": "sindy"},
        complexity=5,
        builds_on="sindy",
        unit_cost=3.0,
        describer="neckid.export.describe:describe_parallel",
        cost="neckid.selection.costs:parallel_cost",
        c_export="neckid.export.c.parallel:c_parallel",
    ),
    Method(
        "koopman",
        "Koopman (EDMD with control)",
        "neckid.models.koopman.model:KoopmanEDMD",
        "Koopman model with control (Korda & Mezic 2018): output and input delays plus"
        " thin-plate RBFs lifted to a linear system by ridge least squares (EDMDc); dictionary"
        " size and ridge by the selection rule",
        quick={"n_observables": 10, "ridge": 1e-6},
        complexity=3,
        unit_cost=2.0,
        describer="neckid.models.koopman.summary:describe_koopman",
        cost="neckid.selection.costs:koopman_cost",
        control_form="ss",
        c_export="neckid.export.c.koopman:c_koopman",
    ),
    Method(
        "sm-parallel-koopman",
        "Set Membership parallel (Koopman)",
        "neckid.models.set_membership.parallel:ParallelSetMembership",
        "Set Membership on the free run of a parallel Koopman model (koopman): guaranteed"
        " one-step bounds around the lifted linear simulator",
        defaults={"base": "koopman"},
        complexity=5,
        builds_on="koopman",
        unit_cost=3.0,
        describer="neckid.export.describe:describe_parallel",
        cost="neckid.selection.costs:parallel_cost",
        c_export="neckid.export.c.parallel:c_parallel",
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
        if m.class_name == type(model).__name__
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
