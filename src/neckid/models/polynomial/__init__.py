"""Polynomial NARX: monomials of the regressor, fitted by least squares and on the free run.

- :mod:`.narx`: :class:`PolynomialNARX`;
- :mod:`.monomials`: which monomials and how they are built (:func:`monomial_tables`);
- :mod:`._kernels`: the compiled free run and its sensitivities (private to this family).
"""

from neckid.models.polynomial.monomials import monomial_tables
from neckid.models.polynomial.narx import PolynomialNARX

__all__ = ["PolynomialNARX", "monomial_tables"]
