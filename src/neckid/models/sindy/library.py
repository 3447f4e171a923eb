r"""The candidate functions of a sparse NARX: monomials of the regressor, sines, cosines, user functions.

A library row is one function ``θ_k`` of the raw regressor ``w(t)`` (the past outputs, inputs and
conditions of :class:`~neckid.Lags`, in their own units):

- ``kind 0``, a monomial ``∏_j w_j^{p_kj}`` of total degree ``<= degree`` (the constant first);
- ``kind 1`` and ``kind 2``, ``sin(ω w_j)`` and ``cos(ω w_j)`` of one term, for each frequency
  ``ω`` of ``trigonometric`` (in radians per unit of the term);
- ``kind 3``, a user function ``f(w_j)`` of one term, for each ``(name, f)`` of ``functions``.

The monomials are of the raw terms, not standardised ones: centring would turn one raw monomial
into a sum of several, and the sparsity the regression finds would not be the equation's. Each
column is scaled to unit root mean square before the regression
(:mod:`neckid.models.sindy.stlsq`); the coefficients are then given back in raw units.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from neckid.models.polynomial.monomials import monomial_tables
from neckid.utils.types import FloatArray, IntArray

__all__ = ["KIND_NAMES", "Library", "build_library"]

#: The kinds of library function, by their code in :attr:`Library.kind`.
KIND_NAMES = ("monomial", "sin", "cos", "function")


@dataclass(frozen=True)
class Library:
    """The library functions of one regressor, as arrays (what a model file stores).

    Attributes
    ----------
    kind : ndarray of int, shape (n_functions,)
        0 monomial, 1 ``sin``, 2 ``cos``, 3 user function (:data:`KIND_NAMES`).
    powers : ndarray of int, shape (n_functions, n_terms)
        Exponents of a monomial (zero for the other kinds).
    var : ndarray of int, shape (n_functions,)
        The term of a one-term function (``-1`` for a monomial).
    frequency : ndarray of float, shape (n_functions,)
        ``ω`` of ``sin``/``cos`` (0 otherwise).
    function : tuple of str
        The user function's name per row (``""`` for the other kinds).
    """

    kind: IntArray
    powers: IntArray
    var: IntArray
    frequency: FloatArray
    function: tuple[str, ...]

    @property
    def size(self) -> int:
        """Functions in the library."""
        return int(self.kind.shape[0])

    @property
    def compiled(self) -> bool:
        """Whether the compiled free run can evaluate every function (no user function)."""
        return not bool(np.any(self.kind == 3))

    def degrees(self) -> IntArray:
        """Total degree of each function (a monomial's; 1 for the one-term functions)."""
        return np.where(self.kind == 0, self.powers.sum(axis=1), 1).astype(np.int64)

    def evaluate(
        self,
        x: FloatArray,
        functions: Mapping[str, Callable[..., object]] | None = None,
        rows: IntArray | None = None,
        hold: tuple[FloatArray, FloatArray] | None = None,
    ) -> FloatArray:
        """The library's columns at the regressor rows ``x``: ``(n_rows, n_functions)``.

        ``rows`` picks library functions (all by default); ``functions`` are the user functions
        by name (needed when the library has some); with ``hold = (low, high)`` the monomials of
        degree >= 2 take each term clipped into ``[low_j, high_j]``.
        """
        picked = np.arange(self.size) if rows is None else np.asarray(rows, dtype=np.int64)
        held = x if hold is None else np.clip(x, hold[0], hold[1])
        out = np.empty((x.shape[0], picked.size))
        for i, k in enumerate(picked):
            source = held if int(self.powers[k].sum()) >= 2 else x
            out[:, i] = self._column(source, int(k), functions)
        return out

    def _column(
        self, x: FloatArray, k: int, functions: Mapping[str, Callable[..., object]] | None
    ) -> FloatArray:
        kind = int(self.kind[k])
        if kind == 0:
            column = np.ones(x.shape[0])
            for j in np.flatnonzero(self.powers[k]):
                for _ in range(int(self.powers[k, j])):  # as the compiled free run multiplies
                    column = column * x[:, j]
            return column
        term = x[:, int(self.var[k])]
        if kind == 1:
            return np.sin(self.frequency[k] * term)
        if kind == 2:
            return np.cos(self.frequency[k] * term)
        name = self.function[k]
        if functions is None or name not in functions:
            raise ValueError(f"the library needs the user function {name!r}; pass functions=...")
        values = np.asarray(functions[name](term), dtype=np.float64)
        if values.shape != term.shape:
            raise ValueError(
                f"user function {name!r} must map an array of {term.shape[0]} values to as many;"
                f" got shape {values.shape}"
            )
        return values

    def names(self, terms: Sequence[str]) -> list[str]:
        """Each function written with the regressor's term names (``incl(t-1)^2 u(t-1)``)."""
        out = []
        for k in range(self.size):
            kind = int(self.kind[k])
            if kind == 0:
                factors = [
                    terms[j] if p == 1 else f"{terms[j]}^{p}"
                    for j, p in enumerate(self.powers[k])
                    if p
                ]
                out.append(" ".join(factors) if factors else "1")
                continue
            term = terms[int(self.var[k])]
            if kind == 3:
                out.append(f"{self.function[k]}({term})")
            else:
                out.append(f"{KIND_NAMES[kind]}({self.frequency[k]:g} {term})")
        return out

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The arrays of a model file (the user functions' names go to the JSON)."""
        return {
            "library_kind": self.kind,
            "library_powers": self.powers,
            "library_var": self.var,
            "library_frequency": self.frequency,
        }


def build_library(
    n_terms: int,
    degree: int,
    trigonometric: Sequence[float] = (),
    functions: Sequence[str] = (),
) -> Library:
    """Every library function of ``n_terms`` regressor terms, monomials first (graded order).

    Examples
    --------
    >>> library = build_library(2, 2, trigonometric=[1.0])
    >>> library.size, library.names(["y(t-1)", "u(t-1)"])[3:6]
    (10, ['y(t-1)^2', 'y(t-1) u(t-1)', 'u(t-1)^2'])
    """
    powers, _, _, _ = monomial_tables(n_terms, degree)
    n_mono = powers.shape[0]
    kind = [0] * n_mono
    var = [-1] * n_mono
    frequency = [0.0] * n_mono
    names = [""] * n_mono
    for omega in trigonometric:
        for code in (1, 2):
            kind += [code] * n_terms
            var += list(range(n_terms))
            frequency += [float(omega)] * n_terms
            names += [""] * n_terms
    for name in functions:
        kind += [3] * n_terms
        var += list(range(n_terms))
        frequency += [0.0] * n_terms
        names += [str(name)] * n_terms
    extra = len(kind) - n_mono
    all_powers = np.vstack([powers, np.zeros((extra, n_terms), dtype=np.int64)])
    return Library(
        np.asarray(kind, dtype=np.int64),
        np.ascontiguousarray(all_powers, dtype=np.int64),
        np.asarray(var, dtype=np.int64),
        np.asarray(frequency, dtype=np.float64),
        tuple(names),
    )
