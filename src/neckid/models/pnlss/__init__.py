"""Polynomial nonlinear state-space models (PNLSS): a linear state space plus monomials.

- :mod:`.model`: :class:`PolynomialStateSpace` (registry name ``pnlss``) and its simulator;
- :mod:`.fitting`: the free-run least-squares problem, its parameter layout and the linear start;
- :mod:`._kernels`: the compiled free run and its sensitivity recursion (private to this family).
"""

from neckid.models.pnlss.model import PolynomialStateSpace, PolynomialStateSpaceSimulator

__all__ = ["PolynomialStateSpace", "PolynomialStateSpaceSimulator"]
