"""What one benchmark run computes once and reuses: exact results, keyed by what was fitted on what.

Several grids and stages of a run need the same fit of the same model on the same data: the
linear ARX whose error scales the Set Membership noise bounds (``sm``, ``sm-linear`` and
``sm-parallel`` on every lag set), the polynomial NARX fitted for simulation that ``poly`` ranks
and refits and that ``sm-parallel-poly`` runs in parallel on the same lag sets and records. A
:class:`SharedFits` remembers them for one run:

- :meth:`SharedFits.fitted`: a fitted estimator per :func:`fit_key` (the class, its
  hyper-parameters and a digest of the training data's values, names and conditions);
- :meth:`SharedFits.arx_scale`: the RMS error of the linear ARX on some lags and data;
- :meth:`SharedFits.polynomial_entries`: the states of the fitted polynomials
  (:mod:`neckid.models.cache`, ``polynomial_fits``), handed to every work unit that fits the
  same polynomial on the same data, in whichever process it runs (:class:`RecordingCache`).

Every value is what a new computation would give (same class, same hyper-parameters, same data),
so sharing changes the time a run takes, not its table. The store is an object the runner makes
and passes on, never module state.
"""

from __future__ import annotations

import hashlib
import math
from collections import Counter
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from sklearn.base import clone

from neckid.data.iodata import IOData, as_experiments
from neckid.metrics import rmse
from neckid.models.cache import ResultCache, array_digest
from neckid.regressors import Lags

__all__ = ["PolynomialEntry", "RecordingCache", "SharedFits", "data_digest", "fit_key"]

#: One state of the ``polynomial_fits`` cache: its key and the fitted attributes.
PolynomialEntry = tuple[bytes, Any]


def data_digest(data: IOData | Sequence[IOData]) -> bytes:
    """A digest of the records' values, sampling periods, channel names and conditions."""
    h = hashlib.blake2b(digest_size=16)
    for record in as_experiments(data, "data"):
        h.update(repr((record.ts, record.input_names, record.output_names)).encode())
        h.update(repr(sorted(record.conditions.items())).encode())
        h.update(array_digest(record.u, record.y))
    return h.digest()


def fit_key(estimator: Any, data: IOData | Sequence[IOData]) -> bytes:
    """A digest of the estimator's class and hyper-parameters and of the training data.

    Two estimators with the same key fitted on data with the same digest give the same model.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> data = IOData(np.arange(20.0), np.arange(20.0) ** 0.5, ts=1.0)
    >>> fit_key(LinearARX(Lags.arx(1, 1)), data) == fit_key(LinearARX(Lags.arx(1, 1)), data)
    True
    >>> fit_key(LinearARX(Lags.arx(1, 1)), data) == fit_key(LinearARX(Lags.arx(2, 1)), data)
    False
    """
    h = hashlib.blake2b(digest_size=16)
    h.update(f"{type(estimator).__module__}.{type(estimator).__qualname__}".encode())
    h.update(repr(sorted(estimator.get_params(deep=False).items())).encode())
    h.update(data_digest(data))
    return h.digest()


class RecordingCache(ResultCache):
    """A ``polynomial_fits`` cache that starts with known states and records the new ones.

    A work unit runs its fits under ``use_caches(polynomial_fits=RecordingCache(known))``: a
    polynomial fitted before (in this or another process) is taken from ``known``, and every
    state put during the unit is in :attr:`added` for the runner to hand on.

    Parameters
    ----------
    known : iterable of (bytes, object)
        States to start with (cache key, fitted attributes).
    max_entries : int, default 8
        Room for states beyond the known ones.

    Examples
    --------
    >>> cache = RecordingCache([(b"a", 1)])
    >>> cache.get(b"a"), cache.added
    (1, [])
    >>> cache.put(b"b", 2)
    >>> cache.added
    [(b'b', 2)]
    """

    def __init__(self, known: Iterable[PolynomialEntry] = (), max_entries: int = 8) -> None:
        entries = list(known)
        super().__init__(max_entries=len(entries) + max_entries)
        for key, value in entries:
            super().put(key, value)
        self.added: list[PolynomialEntry] = []

    def put(self, key: bytes, value: Any) -> None:
        """Store ``value`` under ``key`` and record it in :attr:`added`."""
        super().put(key, value)
        self.added.append((key, value))


class SharedFits:
    """The fits one benchmark run shares between grids, candidates and stages (exact reuse).

    Attributes
    ----------
    reused : collections.Counter
        How many times each kind of result was taken from the store instead of computed
        (``"fits"``, ``"arx_scales"``; the runner adds ``"scores"``, candidates scored once for
        two plans): the report's ``timings["shared"]``.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=200)
    >>> data = IOData(u, np.convolve(u, [0.0, 1.0, 0.5])[:200], ts=1.0)
    >>> shared = SharedFits()
    >>> first = shared.arx_scale(Lags.arx(1, 2), data)
    >>> shared.arx_scale(Lags.arx(1, 2), data) == first, shared.reused["arx_scales"]
    (True, 1)
    """

    def __init__(self) -> None:
        self._fitted: dict[bytes, Any] = {}
        self._scales: dict[tuple[bytes, bool], float] = {}
        self._polynomials: dict[tuple[bytes, str], list[PolynomialEntry]] = {}
        self.reused: Counter[str] = Counter()

    # ------------------------------------------------------------------ fitted models
    def fitted(self, estimator: Any, data: IOData | Sequence[IOData]) -> Any:
        """``clone(estimator).fit(data)``, or the model the store holds for the same pair."""
        key = fit_key(estimator, data)
        if key in self._fitted:
            self.reused["fits"] += 1
            return self._fitted[key]
        model = clone(estimator).fit(data)
        self._fitted[key] = model
        return model

    def add_fitted(self, estimator: Any, data: IOData | Sequence[IOData], model: Any) -> None:
        """Keep ``model``, fitted elsewhere from ``estimator`` on ``data``."""
        self._fitted[fit_key(estimator, data)] = model

    def arx_scale(
        self, lags: Lags, train: IOData | Sequence[IOData], free_run: bool = False
    ) -> float:
        """RMS error of a linear ARX with these lags on the training data (pooled over records).

        The one-step residual by default; with ``free_run``, the free-run error.

        Raises
        ------
        ValueError
            With ``free_run``, when the ARX's free run diverges on the training data.
        """
        from neckid.registry import methods

        estimator = methods()["arx"].make(lags)
        key = (fit_key(estimator, train), bool(free_run))
        if key in self._scales:
            self.reused["arx_scales"] += 1
            value = self._scales[key]
        else:
            model = self.fitted(estimator, train)
            measured, modelled = [], []
            for record in as_experiments(train, "train"):
                result = model.simulate(record) if free_run else model.predict(record)
                measured.append(record.y[result.n_initial :])
                modelled.append(result.y[result.n_initial :])
            runs = np.vstack(modelled)
            finite = bool(np.isfinite(runs).all())
            value = (
                float(rmse(np.vstack(measured), runs)[0]) if finite or not free_run else math.inf
            )
            self._scales[key] = value
        if free_run and not math.isfinite(value):
            raise ValueError(f"the linear ARX with {lags!r} diverges on the training record")
        return value

    # ------------------------------------------------------------------ polynomial states
    def polynomial_entries(self, data: bytes, lags: Lags | None) -> list[PolynomialEntry]:
        """The polynomial states fitted with ``lags`` on the data of digest ``data``."""
        return list(self._polynomials.get((data, repr(lags)), ()))

    def add_polynomial_entries(
        self, data: bytes, lags: Lags | None, entries: Iterable[PolynomialEntry]
    ) -> None:
        """Keep states recorded while fitting with ``lags`` on the data of digest ``data``."""
        self._polynomials.setdefault((data, repr(lags)), []).extend(entries)
