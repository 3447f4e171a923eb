r"""Linear model predictive control on identified models, robust to Set Membership bands.

- :mod:`.problem`: the controller's data (:class:`MPCProblem`, :func:`mpc_problem`): the
  model's difference equation with an integrating disturbance, the prediction matrices, the
  weights, limits and horizon;
- :mod:`.controller`: the controller (:class:`MPCController`), one OSQP solve per step;
- :mod:`.robust`: output constraints tightened by the k-step bands of a Set Membership model
  (:func:`band_tightening`);
- :mod:`.files`: the controller file (``kind`` ``"mpc"``; :func:`save_mpc`, :func:`load_mpc`).

The page ``docs/mpc.md`` has the formulation, what the robust variant guarantees and the
measurements.
"""

from neckid.design.mpc.controller import MPCController, SolveStats
from neckid.design.mpc.problem import (
    DEFAULT_COMMAND_LIMIT,
    DEFAULT_RATE_LIMIT,
    MPCProblem,
    disturbance_gain,
    mpc_problem,
)

__all__ = [
    "DEFAULT_COMMAND_LIMIT",
    "DEFAULT_RATE_LIMIT",
    "MPCController",
    "MPCProblem",
    "SolveStats",
    "disturbance_gain",
    "mpc_problem",
]
