r"""The predictive controller: an :class:`~neckid.design.mpc.problem.MPCProblem` solved by OSQP each step.

:class:`MPCController` follows :class:`neckid.systems.Controller` (``reset()``,
``step(reference, measurement) -> command``), so it runs in :func:`neckid.plant.closed_loop`,
in the lab's loop (:func:`neckid.loops.lab_loop.in_loop_on_log`) and wherever the designed PI
runs. One step:

1. the measurement :math:`y_{k-d}` enters the history; the one-step residual
   :math:`y_{k-d} - \hat y_{k-d}` (the previous step's prediction) moves the disturbance
   estimate, :math:`\hat\delta \leftarrow \hat\delta + L\,(y_{k-d} - \hat y_{k-d})`;
2. the QP of the module :mod:`~neckid.design.mpc.problem` is updated (only its linear term and
   its bounds change: the Hessian and the constraint matrix are set once) and solved by OSQP
   (Stellato, Banjac, Goulart, Bemporad & Boyd, *Math. Prog. Comp.* 12, 2020), warm-started
   from the previous solution shifted by one step;
3. the first move is sent, clipped to :math:`\pm u_{max}` and to the rate limit (the QP already
   keeps it there; the clip makes it exact to the solver's tolerance).

Why OSQP: a sparse ADMM solver written for embedded MPC: its factorisation is kept when only the
linear term and the bounds change, it warm-starts, it returns within a set time
(``time_limit``), it generates C code, and it is well kept (osqp.org, Apache-2.0).

A solve that fails (any status but solved / solved inaccurate) or comes late (wall time above
``deadline``, default the period) is not used: the previous command is held, and the step is
counted (:attr:`MPCController.stats`). A NaN measurement is a failed sensor read: the command is
held and nothing else changes (as the lab's controllers do).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from neckid.design.mpc.problem import MPCProblem
from neckid.utils.types import FloatArray

__all__ = ["SOLVER_SETTINGS", "MPCController", "SolveStats"]

#: OSQP's settings (written in the controller file; the deadline is ``time_limit``).
SOLVER_SETTINGS: dict[str, Any] = {"eps_abs": 1e-4, "eps_rel": 1e-4, "max_iter": 4000}


@dataclass(frozen=True)
class SolveStats:
    """What the solver did over a run (since the last ``reset``).

    Attributes
    ----------
    steps : int
        QPs solved (or tried).
    median_ms, max_ms : float
        Per-step wall time of OSQP's ``solve`` [ms] (NaN before any step).
    median_cpu_ms, max_cpu_ms : float
        The same in CPU time of the calling thread [ms] (``time.thread_time``: what the solve
        costs, without the time other processes took the core).
    failed, late : int
        A status other than solved (not used), and a wall time above the deadline (not used
        unless ``on_late="use"``).
    slack_steps : int
        Steps whose first constrained prediction, :math:`y_{k+1}`, needed the slack (> 1e-6
        deg): the constraint could not be met as tightened there (the robust guarantee is void
        at such a step).
    slack_plans : int
        Steps whose plan needed the slack at any horizon step.
    iterations_max : int
        The most ADMM iterations of one solve.
    """

    steps: int
    median_ms: float
    max_ms: float
    median_cpu_ms: float
    max_cpu_ms: float
    failed: int
    late: int
    slack_steps: int
    slack_plans: int
    iterations_max: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return dict(self.__dict__)


def _sparse(matrix: FloatArray) -> Any:
    import scipy.sparse as sp

    return sp.csc_matrix(matrix)


class MPCController:
    """Linear MPC on an identified model's linear form, solved by OSQP (module docstring).

    Parameters
    ----------
    problem : MPCProblem
        :func:`~neckid.design.mpc.problem.mpc_problem`.
    deadline : float, optional
        Wall time a solve may take [s] (default the period); OSQP's ``time_limit`` too.
    on_late : {"hold", "use"}, default "hold"
        What a late solve does: hold the previous command (a real-time loop), or be counted
        and used all the same (a simulation, whose period is not wall time: its results then
        do not depend on the machine's load; OSQP then has no time limit).

    Attributes
    ----------
    ts : float
    n_references, n_motors : int
        1 and 1.
    kind : str
        ``"mpc"``.

    Examples
    --------
    >>> import control, numpy as np
    >>> from neckid.design import linear_form
    >>> from neckid.design.mpc import mpc_problem
    >>> from neckid.plant import closed_loop
    >>> plant = control.tf([0.1], [1, -1], dt=0.02)   # y_k = y_{k-1} + 0.1 u_{k-1}
    >>> mpc = MPCController(mpc_problem(linear_form(plant), horizon=10))
    >>> class Integrator:
    ...     def reset(self): self.y = 0.0
    ...     def step(self, u): y, self.y = self.y, self.y + 0.1 * float(u[0]); return [y]
    >>> log = closed_loop(Integrator(), mpc, np.full(200, 1.0), ts=0.02)
    >>> round(float(log.y[-1, 0]), 3), float(np.abs(log.u[:, 1]).max()) <= 4.0
    (1.0, True)
    """

    n_references = 1
    n_motors = 1
    kind = "mpc"

    def __init__(
        self,
        problem: MPCProblem,
        *,
        deadline: float | None = None,
        on_late: Literal["hold", "use"] = "hold",
    ) -> None:
        if not isinstance(problem, MPCProblem):
            raise TypeError(f"problem must be an MPCProblem; got {type(problem).__name__}")
        if on_late not in ("hold", "use"):
            raise ValueError(f"on_late must be 'hold' or 'use'; got {on_late!r}")
        self.problem = problem
        self.ts = problem.ts
        self.deadline = problem.ts if deadline is None else float(deadline)
        self.on_late = on_late
        self._future: FloatArray | None = None
        self._setup_matrices()
        self.reset()

    # -- the QP's constant parts ---------------------------------------------------------------

    def _setup_matrices(self) -> None:
        pr = self.problem
        d, nu = pr.delay, pr.control_horizon
        phi = pr.forced[d:]  # rows y_{k+1} ... y_{k+N}
        moves = np.eye(nu) - np.eye(nu, k=-1)  # D U - e1 u_{k-1} = the moves
        hessian = pr.tracking_weight * phi.T @ phi + pr.move_weight * moves.T @ moves
        blocks = [np.eye(nu), moves]
        if pr.constrained:  # one slack per horizon step: a far step's slack leaves step 1 alone
            n = pr.horizon
            hessian = np.block(
                [
                    [hessian, np.zeros((nu, n))],
                    [np.zeros((n, nu)), pr.slack_weight * np.eye(n)],
                ]
            )
            blocks = [
                np.column_stack([np.eye(nu), np.zeros((nu, n))]),
                np.column_stack([moves, np.zeros((nu, n))]),
                np.column_stack([phi, -np.eye(n)]),  # y - s <= max - w
                np.column_stack([phi, np.eye(n)]),  # y + s >= min + w
                np.column_stack([np.zeros((n, nu)), np.eye(n)]),  # s >= 0
            ]
        self._phi = phi
        self._moves = moves
        self._hessian = 2.0 * hessian
        self._constraints = np.vstack(blocks)
        self._n_variables = self._hessian.shape[0]

    def _new_solver(self) -> Any:
        import osqp

        solver = osqp.OSQP()
        n_rows = self._constraints.shape[0]
        solver.setup(
            _sparse(np.triu(self._hessian)),
            np.zeros(self._n_variables),
            _sparse(self._constraints),
            np.full(n_rows, -np.inf),
            np.full(n_rows, np.inf),
            verbose=False,
            warm_starting=True,
            polishing=False,
            **SOLVER_SETTINGS,
            time_limit=self.deadline if self.on_late == "hold" else 1e10,
        )
        return solver

    # -- the controller contract ---------------------------------------------------------------

    def set_reference(self, reference: ArrayLike | None) -> None:
        """The run's whole reference [deg], for the preview (None: hold the current one).

        Step ``k`` after ``reset`` reads ``reference[k + 1 : k + N + 1]`` (the last value held
        beyond the end). Ignored when the problem was designed without preview.
        """
        if reference is None:
            self._future = None
            return
        values = np.asarray(reference, dtype=np.float64).reshape(-1)
        if values.size == 0 or not np.all(np.isfinite(values)):
            raise ValueError("the preview reference must be finite values [deg]")
        self._future = values

    def reset(self) -> None:
        """Back to rest: empty history, zero disturbance, a new solver (no warm start)."""
        pr = self.problem
        self._solver = self._new_solver()
        self._y = np.zeros(pr.a.size)
        self._u = np.zeros(pr.n_past_commands)
        self._delta = 0.0
        self._predicted: float | None = None
        self._started = False
        self._k = 0
        self._last = 0.0
        self._plan = np.zeros(self._n_variables)
        self._times: list[float] = []
        self._cpu: list[float] = []
        self._iterations = 0
        self._failed = self._late = self._slack = self._slack_any = 0

    @property
    def stats(self) -> SolveStats:
        """:class:`SolveStats` since the last ``reset``."""
        times = np.asarray(self._times) * 1e3
        cpu = np.asarray(self._cpu) * 1e3
        return SolveStats(
            steps=len(self._times),
            median_ms=float(np.median(times)) if times.size else math.nan,
            max_ms=float(np.max(times)) if times.size else math.nan,
            median_cpu_ms=float(np.median(cpu)) if cpu.size else math.nan,
            max_cpu_ms=float(np.max(cpu)) if cpu.size else math.nan,
            failed=self._failed,
            late=self._late,
            slack_steps=self._slack,
            slack_plans=self._slack_any,
            iterations_max=self._iterations,
        )

    def _references(self, reference: float) -> FloatArray:
        n = self.problem.horizon
        if self.problem.preview and self._future is not None:
            index = np.minimum(np.arange(self._k + 1, self._k + n + 1), self._future.size - 1)
            return self._future[index]
        return np.full(n, reference)

    def _measure(self, y: float) -> None:
        if not self._started:  # the loop starts at rest at its first measurement
            self._y[:] = y
            self._started = True
        else:
            self._y = np.roll(self._y, 1)
            self._y[0] = y
        if self._predicted is not None:
            self._delta += self.problem.disturbance_gain * (y - self._predicted)

    def step(self, reference: ArrayLike, measurement: ArrayLike) -> FloatArray:
        """One control period.

        Parameters
        ----------
        reference : float
            Inclination reference now [deg] (held over the horizon without preview).
        measurement : float
            The last measured inclination [deg]; NaN: a failed read, the command held.

        Returns
        -------
        ndarray, shape (1,)
            Velocity command [rad/s].
        """
        y = float(np.asarray(measurement, dtype=np.float64).reshape(-1)[0])
        r = float(np.asarray(reference, dtype=np.float64).reshape(-1)[0])
        if math.isnan(y):
            self._k += 1
            return np.array([self._last])
        if not (math.isfinite(r) and math.isfinite(y)):
            raise ValueError(f"reference and measurement must be finite; got {r}, {y}")
        self._measure(y)
        command = self._solve(self._references(r))
        self._advance(command)
        return np.array([command])

    def _solve(self, references: FloatArray) -> float:
        pr = self.problem
        history = np.concatenate([self._y, self._u])
        base = pr.free[pr.delay :] @ history + pr.disturbance[pr.delay :] * self._delta
        gradient = 2.0 * pr.tracking_weight * self._phi.T @ (base - references)
        gradient[0] -= 2.0 * pr.move_weight * self._last
        step = pr.rate_limit * pr.ts
        nu = pr.control_horizon
        ones = np.ones(nu)
        lower = [-pr.command_limit * ones, -step * ones + self._first(self._last)]
        upper = [pr.command_limit * ones, step * ones + self._first(self._last)]
        if pr.constrained:
            n = pr.horizon
            gradient = np.append(gradient, np.full(n, pr.slack_linear_weight))
            lower += [np.full(n, -np.inf), pr.output_min + pr.tightening - base, np.zeros(n)]
            upper += [pr.output_max - pr.tightening - base, np.full(n, np.inf), np.full(n, np.inf)]
        self._solver.update(q=gradient, l=np.concatenate(lower), u=np.concatenate(upper))
        plan = self._plan
        shifted = np.concatenate([plan[1:nu], plan[nu - 1 : nu], plan[nu + 1 :], plan[-1:]])
        self._solver.warm_start(x=shifted[: self._n_variables])
        started, cpu = time.perf_counter(), time.thread_time()
        result = self._solver.solve(raise_error=False)
        elapsed = time.perf_counter() - started
        self._cpu.append(time.thread_time() - cpu)
        self._times.append(elapsed)
        self._iterations = max(self._iterations, int(result.info.iter))
        if int(result.info.status_val) not in (1, 2) or result.x is None:
            self._failed += 1
            return self._last
        if elapsed > self.deadline:
            self._late += 1
            if self.on_late == "hold":
                return self._last
        self._plan = np.asarray(result.x, dtype=np.float64)
        if pr.constrained and self._plan[nu] > 1e-6:
            self._slack += 1
        if pr.constrained and np.max(self._plan[nu:]) > 1e-6:
            self._slack_any += 1
        command = float(self._plan[0])
        command = min(max(command, self._last - step), self._last + step)
        return min(max(command, -pr.command_limit), pr.command_limit)

    def _first(self, value: float) -> FloatArray:
        first = np.zeros(self.problem.control_horizon)
        first[0] = value
        return first

    def _advance(self, command: float) -> None:
        pr = self.problem
        history = np.concatenate([self._y, self._u])
        moves = np.full(pr.control_horizon, command)
        self._predicted = float(pr.predict(history, moves, self._delta)[0])
        self._u = np.roll(self._u, 1)
        self._u[0] = command
        self._last = command
        self._k += 1

    def __deepcopy__(self, memo: dict[int, Any]) -> MPCController:
        """A fresh copy in the same state (the solver rebuilt; it cannot be copied)."""
        import copy

        other = MPCController.__new__(MPCController)
        for name, value in self.__dict__.items():
            if name != "_solver":
                other.__dict__[name] = copy.deepcopy(value, memo)
        other._solver = other._new_solver()
        return other

    def __repr__(self) -> str:
        pr = self.problem
        return (
            f"MPCController(horizon={pr.horizon}, control_horizon={pr.control_horizon},"
            f" ts={pr.ts!r}, command_limit={pr.command_limit!r}, preview={pr.preview},"
            f" constrained={pr.constrained})"
        )
