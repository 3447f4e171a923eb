"""Caches of expensive, deterministic results that estimators reuse: explicit objects, not module state.

Two computations are worth remembering across fits of the same data:

- :data:`GAMMA_CURVES`: γ*(ε) values of a Set Membership training set (digest of its scaled
  regressors and targets -> ``{(output, ε): γ*}``). A selection that fits several SM candidates
  on one regressor walks the pairs once per new ε.
- :data:`POLYNOMIAL_FITS`: fitted :class:`~neckid.models.polynomial.PolynomialNARX` states
  (digest of its parameters and training data -> the fitted attributes). The candidates of
  ``ParallelSetMembership(parallel_degree=3)`` refit the same polynomial. The sparse NARX and
  the Koopman model keep their states there too (:func:`remembered_fit`, keyed by class as
  well): the candidates of ``ParallelSetMembership(base="sindy")`` or ``base="koopman"`` refit
  the same base model, its own selection included.

Both values are exact: a cached value is the value a new computation would give, so a cache
changes only the time a fit takes. Each cache is a :class:`ResultCache` (bounded, least recently
used dropped first, safe to share between threads). A caller can clear them, or run code with
caches of its own (or none) with :func:`use_caches`; the estimators look the active one up
with :func:`active_cache` at each fit.

Examples
--------
>>> from neckid.models.cache import ResultCache, active_cache, use_caches
>>> mine = ResultCache(max_entries=2)
>>> with use_caches(polynomial_fits=mine):
...     active_cache("polynomial_fits") is mine
True
>>> with use_caches(gamma_curves=None):
...     active_cache("gamma_curves") is None
True
"""

from __future__ import annotations

import copy
import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from typing import TYPE_CHECKING, Any, Literal, TypeVar

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from neckid.data.iodata import IOData

_Model = TypeVar("_Model")

__all__ = [
    "GAMMA_CURVES",
    "POLYNOMIAL_FITS",
    "CacheName",
    "ResultCache",
    "active_cache",
    "array_digest",
    "remembered_fit",
    "use_caches",
]

#: The caches an estimator may look up.
CacheName = Literal["gamma_curves", "polynomial_fits"]


class ResultCache:
    """A bounded map from a digest to a result, least recently used dropped first; thread-safe.

    Parameters
    ----------
    max_entries : int, default 8
        How many results it keeps.

    Examples
    --------
    >>> cache = ResultCache(max_entries=1)
    >>> cache.put(b"a", 1); cache.put(b"b", 2)
    >>> cache.get(b"a") is None, cache.get(b"b"), len(cache)
    (True, 2, 1)
    """

    def __init__(self, max_entries: int = 8) -> None:
        if isinstance(max_entries, bool) or not isinstance(max_entries, int) or max_entries < 1:
            raise ValueError(f"max_entries must be an integer >= 1; got {max_entries!r}")
        self.max_entries = max_entries
        self._entries: OrderedDict[bytes, Any] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: bytes) -> Any | None:
        """The result stored under ``key`` (now the most recently used), or ``None``."""
        with self._lock:
            value = self._entries.get(key)
            if value is not None:
                self._entries.move_to_end(key)
            return value

    def put(self, key: bytes, value: Any) -> None:
        """Store ``value`` under ``key``; drop the least recently used beyond ``max_entries``."""
        with self._lock:
            self._entries[key] = value
            self._entries.move_to_end(key)
            while len(self._entries) > self.max_entries:
                self._entries.popitem(last=False)

    def clear(self) -> None:
        """Forget every result."""
        with self._lock:
            self._entries.clear()

    def __len__(self) -> int:
        with self._lock:
            return len(self._entries)

    def __repr__(self) -> str:
        return f"ResultCache(max_entries={self.max_entries}, entries={len(self)})"


#: γ*(ε) values per Set Membership training set, shared by the process unless replaced.
GAMMA_CURVES = ResultCache(max_entries=8)
#: Fitted polynomial NARX states, shared by the process unless replaced.
POLYNOMIAL_FITS = ResultCache(max_entries=8)

#: The caches in use, when a block replaced them (see :func:`use_caches`); ``None``: the defaults.
_ACTIVE: ContextVar[Mapping[str, ResultCache | None] | None] = ContextVar(
    "neckid_caches", default=None
)


def _current() -> dict[str, ResultCache | None]:
    replaced = _ACTIVE.get()
    if replaced is None:
        return {"gamma_curves": GAMMA_CURVES, "polynomial_fits": POLYNOMIAL_FITS}
    return dict(replaced)


def active_cache(name: CacheName) -> ResultCache | None:
    """The cache ``name`` in use in this context (``None`` when caching is off for it)."""
    caches = _current()
    if name not in caches:
        raise ValueError(f"name must be 'gamma_curves' or 'polynomial_fits'; got {name!r}")
    return caches[name]


@contextmanager
def use_caches(**caches: ResultCache | None) -> Iterator[None]:
    """Run a block with other caches (``None`` turns one off), e.g. ``use_caches(gamma_curves=None)``.

    Applies to this thread or task only (a :class:`contextvars.ContextVar`); worker threads that
    a sweep starts use the process-wide caches.
    """
    current = _current()
    for name, cache in caches.items():
        if name not in current:
            raise ValueError(f"unknown cache {name!r}; the caches are {sorted(current)}")
        if cache is not None and not isinstance(cache, ResultCache):
            raise TypeError(f"{name} must be a ResultCache or None; got {type(cache).__name__}")
        current[name] = cache
    token = _ACTIVE.set(current)
    try:
        yield
    finally:
        _ACTIVE.reset(token)


def array_digest(*arrays: ArrayLike) -> bytes:
    """A digest of each array's shape and float64 bytes, in order (BLAKE2b, 16 bytes)."""
    h = hashlib.blake2b(digest_size=16)
    for array in arrays:
        values = np.ascontiguousarray(array, dtype=np.float64)
        h.update(np.asarray(values.shape, dtype=np.int64).tobytes())
        h.update(values.data)
    return h.digest()


def _state_key(model: Any, data: IOData | Sequence[IOData]) -> bytes:
    """A digest of the model's class and parameters and the training data (values, names, conditions)."""
    from neckid.data.iodata import as_experiments

    h = hashlib.blake2b(digest_size=16)
    h.update(f"{type(model).__module__}.{type(model).__qualname__}".encode())
    h.update(repr(sorted(model.get_params(deep=False).items())).encode())
    for record in as_experiments(data, "data"):
        h.update(repr((record.ts, record.input_names, record.output_names)).encode())
        h.update(repr(sorted(record.conditions.items())).encode())
        h.update(array_digest(record.u, record.y))
    return h.digest()


def remembered_fit(
    model: _Model, data: IOData | Sequence[IOData], fit: Callable[[], Any]
) -> _Model:
    """``fit()`` on ``model``, or the fitted state the active ``polynomial_fits`` cache holds.

    The state is ``model.__dict__`` after ``fit()`` (a deep copy each way), keyed by the class,
    the parameters and the data as the fit reads them (with the model's conditions appended as
    inputs), so a cached state is the one a new fit gives. ``fit`` must
    depend on nothing else (no callables among the parameters: their text is an address).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> data = IOData(np.arange(20.0), np.arange(20.0) ** 0.5, ts=1.0)
    >>> with use_caches(polynomial_fits=ResultCache()):
    ...     first = LinearARX(Lags.arx(1, 1))
    ...     _ = remembered_fit(first, data, lambda: first.fit(data))
    ...     second = LinearARX(Lags.arx(1, 1))
    ...     _ = remembered_fit(second, data, lambda: 1 / 0)  # not called: the state is cached
    >>> bool(np.array_equal(first.coef_, second.coef_))
    True
    """
    cache = active_cache("polynomial_fits")
    if cache is None:
        fit()
        return model
    # Keyed on the data as the fit reads them (conditions appended as inputs, which is
    # idempotent): a Set Membership model hands its base the logs with them appended already.
    with_conditions = getattr(model, "_with_conditions", None)
    key = _state_key(model, data if with_conditions is None else with_conditions(data, True))
    cached = cache.get(key)
    if cached is not None:
        model.__dict__.update(copy.deepcopy(cached))
        return model
    fit()
    cache.put(key, copy.deepcopy(model.__dict__))
    return model
