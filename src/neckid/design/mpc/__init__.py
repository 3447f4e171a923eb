r"""Linear model predictive control on identified models, robust to Set Membership bands.

- :mod:`.problem`: the controller's data (:class:`MPCProblem`, :func:`mpc_problem`): the
  model's difference equation with an integrating disturbance, the prediction matrices, the
  weights, limits and horizon;
- :mod:`.controller`: the controller (:class:`MPCController`), one OSQP solve per step;
- :mod:`.robust`: output constraints tightened by the k-step bands of a Set Membership model
  (:func:`band_tightening`), and the design from a model (:func:`design_mpc`);
- :mod:`.files`: the controller file (``kind`` ``"mpc"``; :func:`save_mpc`, :func:`load_mpc`).

The page ``docs/mpc.md`` has the formulation, what the robust variant guarantees and the
measurements.
"""

from neckid.design.mpc.controller import MPCController, SolveStats
from neckid.design.mpc.files import load_mpc, mpc_document, save_mpc
from neckid.design.mpc.problem import (
    DEFAULT_COMMAND_LIMIT,
    DEFAULT_RATE_LIMIT,
    MPCProblem,
    disturbance_gain,
    mpc_problem,
    prediction_matrices,
)
from neckid.design.mpc.robust import (
    BandTightening,
    band_tightening,
    controller_predictions,
    design_mpc,
)

__all__ = [
    "DEFAULT_COMMAND_LIMIT",
    "DEFAULT_RATE_LIMIT",
    "BandTightening",
    "MPCController",
    "MPCProblem",
    "SolveStats",
    "band_tightening",
    "controller_predictions",
    "design_mpc",
    "disturbance_gain",
    "load_mpc",
    "mpc_document",
    "mpc_problem",
    "prediction_matrices",
    "save_mpc",
]
