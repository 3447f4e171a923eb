"""Sparse identification (SINDy with control, discrete time): few terms of a function library.

- :mod:`.model`: :class:`SparseNARX`;
- :mod:`.library`: the candidate functions (monomials, sines and cosines, user functions);
- :mod:`.stlsq`: sequentially thresholded least squares on scaled columns;
- :mod:`.selection`: the threshold by the selection rule on the training data;
- :mod:`.summary`: the equation with units (``neckid info``), the export describer;
- :mod:`._kernels`: the compiled free run (private to this family).
"""

from neckid.models.sindy.model import SparseNARX

__all__ = ["SparseNARX"]
