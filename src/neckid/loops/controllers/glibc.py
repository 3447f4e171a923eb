r"""glibc's ``rand()``: the TYPE_3 additive feedback generator, the source of the lab's dither.

The bench programs never call ``srand``, so ``rand()`` runs from glibc's default seed 1. glibc's
``random_r`` with its default 128-byte state (TYPE_3: degree 31, separation 3) seeds 31 words by
a Lehmer generator and then discards 310 outputs; this module reproduces it bit for bit, in pure
Python integers.

References
----------
- ``neckid/../shared/data/softneck/CONTROLLERS.md``, section "What every run shares" (the
  recurrence and the 24 outputs the bench consumes before its control loop).
- The GNU C Library, ``stdlib/random_r.c`` (``__srandom_r``, ``__random_r``), TYPE_3.
- S. K. Park and K. W. Miller, "Random number generators: good ones are hard to find",
  *Communications of the ACM* 31 (10), 1988 (the seeding multiplier 16807 mod 2^31 − 1).
"""

from __future__ import annotations

import numpy as np

from neckid.utils.types import IntArray

__all__ = ["GLIBC_RAND_MAX", "GlibcRandom", "glibc_rand"]

#: The largest value ``rand()`` returns (2^31 − 1).
GLIBC_RAND_MAX = 2**31 - 1

_DEGREE = 31  # r_i depends on r_{i-31} ...
_SEPARATION = 3  # ... and on r_{i-3}
_DISCARDED = 10 * _DEGREE  # outputs thrown away by srandom: 310
_MODULUS = 2**31 - 1
_WORD = 2**32


def _int32(value: int) -> int:
    """``value`` as C's ``int32_t`` (two's complement wrap)."""
    value &= _WORD - 1
    return value - _WORD if value >= 2**31 else value


class GlibcRandom:
    r"""The sequence of glibc's ``rand()`` (and ``random()``) after ``srand(seed)``.

    Parameters
    ----------
    seed : int, default 1
        The seed, as ``srand(unsigned int)`` takes it; 0 acts as 1 (as in glibc). The default is
        the seed of a program that never calls ``srand``.

    Notes
    -----
    Seeding fills :math:`r_0 = \mathrm{seed}` and
    :math:`r_i = 16807\,r_{i-1} \bmod (2^{31}-1)` for :math:`i = 1 \ldots 30` (computed as glibc
    does, by Schrage's method on signed 32-bit words), then :math:`r_i = r_{i-31}` for
    :math:`i = 31 \ldots 33` and, for :math:`i \ge 34`,

    .. math:: r_i = (r_{i-31} + r_{i-3}) \bmod 2^{32}.

    The :math:`k`-th output (:math:`k = 0, 1, \ldots`) is :math:`r_{k+344} \gg 1`, in
    :math:`[0, 2^{31} - 1]`.

    References
    ----------
    CONTROLLERS.md ("What every run shares"); glibc ``stdlib/random_r.c``.

    Examples
    --------
    >>> rng = GlibcRandom()
    >>> [rng.rand() for _ in range(3)]
    [1804289383, 846930886, 1681692777]
    """

    def __init__(self, seed: int = 1) -> None:
        if not isinstance(seed, int | np.integer) or not 0 <= int(seed) < _WORD:
            raise ValueError(f"seed must be an unsigned 32-bit integer; got {seed!r}")
        self.seed = int(seed)
        self.reset()

    def reset(self) -> None:
        """Seed again: the next :meth:`rand` is output 0."""
        word = _int32(self.seed if self.seed else 1)
        words = [word]
        for _ in range(1, _DEGREE):
            # Schrage: 16807 * word mod (2^31 - 1) without overflowing 32 bits (C division).
            hi = int(word / 127773)
            lo = word - hi * 127773
            word = 16807 * lo - 2836 * hi
            if word < 0:
                word += _MODULUS
            words.append(word)
        words = [w & (_WORD - 1) for w in words]
        words += words[:_SEPARATION]  # r_31 .. r_33 = r_0 .. r_2
        # The ring holds r_{i-31} .. r_{i-1} for the next i (34), oldest at _index.
        self._ring = words[-_DEGREE:]
        self._index = 0
        for _ in range(_DISCARDED):  # r_34 .. r_343
            self._advance()
        self.count = 0

    def _advance(self) -> int:
        # ring holds r_{i-31} .. r_{i-1}, oldest first at _index.
        oldest = self._ring[self._index]
        recent = self._ring[(self._index + _DEGREE - _SEPARATION) % _DEGREE]
        value = (oldest + recent) % _WORD
        self._ring[self._index] = value
        self._index = (self._index + 1) % _DEGREE
        return value

    def rand(self) -> int:
        """The next output of ``rand()``, in ``[0, 2**31 - 1]``."""
        return self._advance() >> 1

    def draw(self, n: int) -> IntArray:
        """The next ``n`` outputs.

        Parameters
        ----------
        n : int
            How many (``n >= 0``).

        Returns
        -------
        ndarray of int64, shape (n,)
        """
        if n < 0:
            raise ValueError(f"n must be >= 0; got {n}")
        return np.array([self.rand() for _ in range(n)], dtype=np.int64)

    def skip(self, n: int) -> None:
        """Discard the next ``n`` outputs (the ``rand()`` calls a program made before)."""
        for _ in range(n):
            self.rand()


def glibc_rand(n: int, start: int = 0, seed: int = 1) -> IntArray:
    """Outputs ``start`` … ``start + n − 1`` of glibc's ``rand()`` after ``srand(seed)``.

    Parameters
    ----------
    n : int
        Number of outputs.
    start : int, default 0
        Index of the first output (the bench's control loop starts at output 24).
    seed : int, default 1
        glibc's default seed.

    Returns
    -------
    ndarray of int64, shape (n,)

    Examples
    --------
    >>> glibc_rand(5).tolist()
    [1804289383, 846930886, 1681692777, 1714636915, 1957747793]
    """
    if start < 0:
        raise ValueError(f"start must be >= 0; got {start}")
    rng = GlibcRandom(seed)
    rng.skip(start)
    return rng.draw(n)
