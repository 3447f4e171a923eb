"""The monomials of a polynomial NARX: which products of which regressor terms, and how to build them.

Shared by the polynomial NARX (its compiled free run builds monomial ``m`` as monomial
``parent[m]`` times one term) and by the Set Membership family's learnt distance, which
differentiates a polynomial fitted to the SM targets.
"""

from __future__ import annotations

import functools
import itertools

import numpy as np

from neckid.utils.types import IntArray

__all__ = ["monomial_tables"]


def monomial_tables(n_terms: int, degree: int) -> tuple[IntArray, IntArray, IntArray, IntArray]:
    """The monomials of degree <= ``degree`` in ``n_terms`` variables, graded, and how to build them.

    Returns
    -------
    powers : ndarray of int, shape (n_monomials, n_terms)
        Exponents; row 0 is the constant, then degree 1 (``x̃_0``, ``x̃_1``, ...), degree 2 in
        lexicographic order (``x̃_0²``, ``x̃_0 x̃_1``, ...), and so on.
    parent, var : ndarray of int, shape (n_monomials,)
        Monomial ``m`` = monomial ``parent[m]`` · ``x̃[var[m]]`` (``-1`` for the constant).
    lower : ndarray of int, shape (n_monomials, n_terms)
        The monomial with one factor ``x̃_j`` fewer, ``-1`` where ``x̃_j`` does not appear.

    Examples
    --------
    >>> powers, parent, var, lower = monomial_tables(2, 2)
    >>> powers.tolist()
    [[0, 0], [1, 0], [0, 1], [2, 0], [1, 1], [0, 2]]
    >>> parent.tolist(), var.tolist()
    ([-1, 0, 0, 1, 1, 2], [-1, 0, 1, 0, 1, 1])
    """
    # Built once per (n_terms, degree): the model asks for them at every one-step call (a
    # simulator step included); the caller gets its own copies.
    powers, parent, var, lower = _tables(n_terms, degree)
    return powers.copy(), parent.copy(), var.copy(), lower.copy()


@functools.lru_cache(maxsize=64)
def _tables(n_terms: int, degree: int) -> tuple[IntArray, IntArray, IntArray, IntArray]:
    """:func:`monomial_tables`, built once per ``(n_terms, degree)`` (never hand these out)."""
    combos: list[tuple[int, ...]] = [()]
    for d in range(1, degree + 1):
        combos.extend(itertools.combinations_with_replacement(range(n_terms), d))
    index = {c: i for i, c in enumerate(combos)}
    n_mono = len(combos)
    powers = np.zeros((n_mono, n_terms), dtype=np.int64)
    parent = np.full(n_mono, -1, dtype=np.int64)
    var = np.full(n_mono, -1, dtype=np.int64)
    lower = np.full((n_mono, n_terms), -1, dtype=np.int64)
    for m, combo in enumerate(combos):
        for j in combo:
            powers[m, j] += 1
        if combo:
            parent[m] = index[combo[:-1]]
            var[m] = combo[-1]
        for j in set(combo):
            reduced = list(combo)
            reduced.remove(j)
            lower[m, j] = index[tuple(reduced)]
    return powers, parent, var, lower
