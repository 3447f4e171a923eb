"""What one fit of a method is expected to cost, from its own settings and the data's size.

A selection's progress (:func:`neckid.selection.work.progress_units`) weighs each unit of work
(one candidate fitted on one split and scored on its folds) by its expected cost, and
:class:`neckid.utils.progress.Plan` turns the costs into the time left with the seconds per
cost unit of the units done so far. A constant per method cannot fit: a neural NARX with its
defaults (five 2×25 networks, up to 1000 epochs) costs about fifty Set Membership fits, with its
quick settings (two networks of 8, 50 epochs) about one. So every method names, in the registry
(:attr:`neckid.registry.Method.cost`), one function here::

    cost(estimator, n_samples, n_terms) -> float

reading the estimator's hyper-parameters (``get_params``). ``n_samples`` is the training
samples of the split, ``n_terms`` the regressor terms of the candidate's lags on the data (for a
model whose regressor is not its lags, the data's input and output channels).

The unit is that of :attr:`~neckid.registry.Method.unit_cost` times samples (a method without a
cost function counts so): about a sample of a polynomial, subspace or neural fit. The constants
were measured side by side on the payload split by ``benchmarks/bench_unit_costs.py``: single
fits, then every unit of a ``compare`` (its docstring gives the commands, the loads and the
seconds); only their ratios matter. Set Membership's come from the ``compare``: its tree walks
use both cores where most other fits use one, so under load it is cheaper beside them than a
single fit on a quieter machine shows (about 2× at load 3.5 against 2).
"""

from __future__ import annotations

import itertools
import math
from typing import Any

__all__ = [
    "arx_cost",
    "koopman_cost",
    "multistep_cost",
    "neural_cost",
    "parallel_cost",
    "pnlss_cost",
    "polynomial_cost",
    "set_membership_cost",
    "sindy_cost",
    "subspace_cost",
]

#: Per-method constants [cost unit per operation of the formula], from bench_unit_costs.py.
_ARX = 0.016
_SM = 0.45
_MULTISTEP = 0.9
_PARALLEL = 0.62
_SUBSPACE_PROJECTION = 6.0e-4
_SUBSPACE_REFINE = 4.8e-4
_PNLSS = 0.0126
_POLYNOMIAL = 0.00033
_POLYNOMIAL_START = 25
_NEURAL = 0.00073
_NEURAL_EPOCH = 1000
_KOOPMAN = 1.15e-4
_KOOPMAN_BASE = 0.064
_SINDY = 0.00037

#: Epochs a network trained with early stopping is counted for, at most (it stops when the
#: validation score has not improved for ``n_iter_no_change`` epochs, well before 1000).
_EARLY_STOP_EPOCHS = 150

#: The state order counted for a subspace or PNLSS model whose order comes from the data.
_TYPICAL_ORDER = 5

#: The dictionary sizes and ridges a Koopman model tries when they are not given
#: (:data:`neckid.models.koopman.selection.SIZES`, ``RIDGES``): their sum and count.
_KOOPMAN_SIZES = (0, 10, 25, 50, 100)
_KOOPMAN_RIDGES = 4

#: The thresholds a sparse NARX tries when none are given (``DEFAULT_THRESHOLDS``).
_SINDY_THRESHOLDS = 7


def _params(estimator: Any) -> dict[str, Any]:
    getter = getattr(estimator, "get_params", None)
    return dict(getter(deep=False)) if getter is not None else {}


def _sorting(n_samples: int) -> float:
    """``n log n`` rows, relative to 10,000 rows (a tree built and queried on every row)."""
    n = max(int(n_samples), 2)
    return n * math.log2(n) / math.log2(10_000)


def _monomials(n_variables: int, degree: int) -> int:
    """Monomials of degree 1 to ``degree`` in ``n_variables`` variables (the constant left out)."""
    return math.comb(max(n_variables, 0) + max(degree, 0), max(degree, 0)) - 1


def arx_cost(estimator: Any, n_samples: int, n_terms: int) -> float:
    """Linear least squares: ``n · p`` (the regressor built and solved, the free run scored).

    Examples
    --------
    >>> from neckid import Lags, LinearARX
    >>> arx_cost(LinearARX(Lags.arx(2, 2)), 10_000, 4) < arx_cost(LinearARX(), 10_000, 8)
    True
    """
    return _ARX * n_samples * (1 + n_terms)


def set_membership_cost(estimator: Any, n_samples: int, n_terms: int) -> float:
    """A tree over the training rows, queried by each of them: ``n log n``.

    Examples
    --------
    >>> from neckid import SetMembership
    >>> set_membership_cost(SetMembership(), 10_000, 4)
    4500.0
    """
    return _SM * _sorting(n_samples)


def multistep_cost(estimator: Any, n_samples: int, n_terms: int) -> float:
    """One Set Membership fit per horizon ``k``, on ``p + k`` terms: ``Σ_k (p + k) · n log n``.

    Examples
    --------
    >>> from neckid import methods
    >>> short, long = methods()["sm-multistep"].make(horizon=3), methods()["sm-multistep"].make()
    >>> multistep_cost(short, 10_000, 4) < multistep_cost(long, 10_000, 4)
    True
    """
    params = _params(estimator)
    horizons = params.get("horizons")
    steps = (
        list(horizons) if horizons is not None else range(1, int(params.get("horizon") or 10) + 1)
    )
    return _MULTISTEP * sum(n_terms + k for k in steps) * _sorting(n_samples)


def parallel_cost(estimator: Any, n_samples: int, n_terms: int) -> float:
    """A Set Membership fit on a base model's free run, plus the base model's own fit.

    The base is a linear ARX (the default), a polynomial NARX fitted for simulation
    (``parallel_degree > 1``), or the registry method named by ``base``.
    """
    params = _params(estimator)
    total = _PARALLEL * _sorting(n_samples)
    base = params.get("base")
    if isinstance(base, str) and base in _BASE_COSTS:
        return total + _BASE_COSTS[base](_DEFAULTS_OF[base], n_samples, n_terms)
    degree = int(params.get("parallel_degree") or 1)
    if degree > 1:
        total += _POLYNOMIAL * 100 * n_samples * _monomials(n_terms, degree)
    return total + arx_cost(estimator, n_samples, n_terms)


def _state_space(params: dict[str, Any], n_channels: int) -> tuple[int, int, int]:
    order = params.get("order")
    states = order if isinstance(order, int) else _TYPICAL_ORDER
    horizon = int(params.get("horizon") or max(10, states + 1))
    return states, horizon, int(params.get("max_iter") or 0)


def subspace_cost(estimator: Any, n_samples: int, n_terms: int) -> float:
    """PO-MOESP's projections ``n (h c)²`` plus the refinement's ``iterations · n · x (x + c)``.

    ``h`` block rows, ``c`` channels (``n_terms`` for this model), ``x`` states (the order, or
    a typical 5 when the singular values choose it).

    Examples
    --------
    >>> from neckid import methods
    >>> small, big = methods()["ss"].make(order=2), methods()["ss"].make(order=8)
    >>> subspace_cost(small, 10_000, 3) < subspace_cost(big, 10_000, 3)
    True
    """
    params = _params(estimator)
    states, horizon, iterations = _state_space(params, n_terms)
    projection = _SUBSPACE_PROJECTION * n_samples * (horizon * n_terms) ** 2
    refined = params.get("refine", True)
    refine = _SUBSPACE_REFINE * iterations * n_samples * states * (states + n_terms)
    return projection + (refine if refined else 0.0)


def pnlss_cost(estimator: Any, n_samples: int, n_terms: int) -> float:
    """The subspace start plus ``iterations · n · x · M`` (``M`` monomials of states and inputs)."""
    params = _params(estimator)
    states, _, iterations = _state_space(params, n_terms)
    terms = _monomials(states + n_terms, int(params.get("degree") or 3))
    start = subspace_cost(estimator, n_samples, n_terms)
    return start + _PNLSS * iterations * n_samples * states * terms


def polynomial_cost(estimator: Any, n_samples: int, n_terms: int) -> float:
    """Least squares then a free-run fit: ``(s + iterations) · n · M`` (``M`` monomials of the terms).

    ``s`` (:data:`_POLYNOMIAL_START`) counts the least squares and the fit's set-up in
    iterations.

    Examples
    --------
    >>> from neckid import Lags, PolynomialNARX
    >>> quick = PolynomialNARX(Lags.arx(2, 2), degree=2, max_iter=10)
    >>> polynomial_cost(quick, 10_000, 4) < polynomial_cost(PolynomialNARX(Lags.arx(2, 2)), 10_000, 4)
    True
    """
    params = _params(estimator)
    terms = _monomials(n_terms, int(params.get("degree") or 3))
    refine = int(params.get("max_iter") or 0) if params.get("fit_for") != "prediction" else 0
    iterations = _POLYNOMIAL_START + refine
    return _POLYNOMIAL * iterations * n_samples * terms


def neural_cost(estimator: Any, n_samples: int, n_terms: int) -> float:
    """``networks · epochs · n · (weights + w0)``: every network trained on every row every epoch.

    The epochs are ``max_iter``, at most :data:`_EARLY_STOP_EPOCHS` with early stopping; ``w0``
    (:data:`_NEURAL_EPOCH`) is the work of a mini-batch besides its weights, in weights.

    Examples
    --------
    >>> from neckid import Lags, NeuralNARX
    >>> one = NeuralNARX(Lags.arx(2, 2), n_networks=1)
    >>> neural_cost(one, 10_000, 4) < neural_cost(NeuralNARX(Lags.arx(2, 2)), 10_000, 4)
    True
    """
    params = _params(estimator)
    sizes = [n_terms, *tuple(params.get("hidden_layer_sizes") or (25, 25)), 1]
    weights = sum((a + 1) * b for a, b in itertools.pairwise(sizes))
    epochs = int(params.get("max_iter") or 1000)
    if params.get("early_stopping", True):
        epochs = min(epochs, _EARLY_STOP_EPOCHS)
    networks = int(params.get("n_networks") or 1)
    return _NEURAL * networks * epochs * n_samples * (weights + _NEURAL_EPOCH) / 100


def koopman_cost(estimator: Any, n_samples: int, n_terms: int) -> float:
    """Ridge least squares on ``K`` observables, ``n (p + K)²`` per candidate, plus the set-up ``n``."""
    params = _params(estimator)
    given = params.get("n_observables")
    sizes = (given,) if given is not None else _KOOPMAN_SIZES
    ridges = 1 if params.get("ridge") is not None else _KOOPMAN_RIDGES
    per_size = sum((n_terms + size) ** 2 for size in sizes)
    return n_samples * (_KOOPMAN_BASE + _KOOPMAN * per_size * ridges)


def sindy_cost(estimator: Any, n_samples: int, n_terms: int) -> float:
    """STLSQ per threshold on ``M`` monomials, then a free-run fit: ``(T + iterations) · n · M``."""
    params = _params(estimator)
    terms = _monomials(n_terms, int(params.get("degree") or 3))
    given = params.get("thresholds")
    thresholds = len(given) if given is not None else _SINDY_THRESHOLDS
    iterations = int(params.get("max_iter") or 0) if params.get("fit_for") != "prediction" else 0
    return _SINDY * (thresholds + iterations) * n_samples * terms


class _Defaults:
    """An estimator stand-in with a method's default settings (a parallel model's base)."""

    def get_params(self, deep: bool = False) -> dict[str, Any]:
        return {}


_DEFAULTS_OF: dict[str, Any] = {"koopman": _Defaults(), "sindy": _Defaults()}
_BASE_COSTS = {"koopman": koopman_cost, "sindy": sindy_cost}
