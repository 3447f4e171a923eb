"""Linear models: ARX by least squares and ARX by recursive least squares (CFF-RLS).

- :class:`LinearARX` (:mod:`.arx`): batch least squares, the reference every other model is
  compared with; :func:`least_squares`, :func:`linear_free_run`, :func:`linear_sum` are shared with
  the models that have a linear part.
- :class:`RecursiveARX` (:mod:`.rls`): recursive least squares with a constant forgetting factor,
  the estimator of the reference paper's operating points.
- :class:`LeastSquaresStatistics` (:mod:`.ls_statistics`): standard errors and the like.
- :class:`SubspaceStateSpace` (:mod:`.subspace`, steps in :mod:`.subspace_steps`): a MIMO
  state-space model by subspace identification (PO-MOESP), stable, MATLAB's ``n4sid`` model.
"""

from neckid.models.linear.arx import LinearARX, least_squares, linear_free_run, linear_sum
from neckid.models.linear.ls_statistics import LeastSquaresStatistics
from neckid.models.linear.rls import Convergence, RecursiveARX, rls_reference
from neckid.models.linear.subspace import SubspaceStateSpace

__all__ = [
    "Convergence",
    "LeastSquaresStatistics",
    "LinearARX",
    "RecursiveARX",
    "SubspaceStateSpace",
    "least_squares",
    "linear_free_run",
    "linear_sum",
    "rls_reference",
]
