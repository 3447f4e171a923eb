"""C exports of the designed controllers (issue 44): their commands against ``closed_loop``'s.

A PI (the Tustin integrator, saturated), fractional controllers (the lab's Grünwald–Letnikov sum,
Oustaloup's filter) and a scheduled PI run in :func:`neckid.plant.closed_loop` on the simulated
neck; the compiled export is fed the same references and the measurements the loop gave it (the
inclination of the sample before, 0 at first) and must give the same commands to 1e-12 of their
scale. Skipped without a C compiler.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from _c_export import build, relative_error, run
from neckid.design.controllers import DesignedController, GainSchedule
from neckid.design.operators import (
    grunwald_letnikov_operator,
    oustaloup_operator,
    tustin_integrator,
)
from neckid.plant import SoftNeck, closed_loop

TS = 0.02


def _controllers() -> dict[str, DesignedController]:
    schedule = GainSchedule(np.array([0.0, 15.0, 30.0]), np.array([0.3, 0.2, 0.1]),
                            np.array([0.6, 0.4, 0.3]))  # fmt: skip
    return {
        "pi": DesignedController(0.4, 0.8, tustin_integrator(TS), command_limit=1.5),
        "gl": DesignedController(0.3, 0.5, grunwald_letnikov_operator(-0.6, TS)),
        "oustaloup": DesignedController(
            0.3, 0.5, oustaloup_operator(-0.5, TS, (0.05, 50.0), 3), command_limit=2.0
        ),
        "scheduled-pi": DesignedController(0.0, 0.0, tustin_integrator(TS), schedule=schedule),
    }


def _reference(n: int) -> np.ndarray:
    return np.repeat([10.0, 25.0, 15.0, 30.0], n // 4)


@pytest.mark.parametrize("kind", list(_controllers()))
def test_controller_commands_match_closed_loop(kind: str, tmp_path: Path) -> None:
    controller = _controllers()[kind]
    reference = _reference(400)
    log = closed_loop(SoftNeck(), controller, reference, ts=TS)
    commands = log.u[:, list(log.input_names).index("velocity_command")]
    measured = np.concatenate([[0.0], log.y[:-1, 0]])  # command k reads output k - 1
    program = build(controller, tmp_path, "ctl")
    got = run(program, np.column_stack([reference, measured]))[:, 0]
    assert relative_error(got, commands) <= 1e-12
    if controller.command_limit is not None:
        assert np.max(np.abs(got)) <= controller.command_limit


def test_a_failed_read_holds_the_last_command(tmp_path: Path) -> None:
    controller = _controllers()["gl"]
    rows = np.array([[10.0, 0.0], [10.0, 1.0], [10.0, np.nan], [10.0, 2.0], [12.0, 3.0]])
    controller.reset()
    want = np.array([controller.step(r, y)[0] for r, y in rows])
    got = run(build(controller, tmp_path, "ctl"), rows)[:, 0]
    assert relative_error(got, want) <= 1e-12 and got[2] == got[1]


def test_cli_exports_a_controller_file(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from neckid.cli import app
    from neckid.design.files import controller_document

    path = tmp_path / "pi.json"
    path.write_text(json.dumps(controller_document(_controllers()["pi"])))
    result = CliRunner().invoke(
        app, ["export", str(path), "--to", "c", "--out", str(tmp_path / "c"), "--name", "pi"]
    )
    assert result.exit_code == 0, result.output
    header = (tmp_path / "c" / "pi.h").read_text()
    assert "double pi_step(pi_state *s, double reference, double measurement);" in header
    assert "class pi_controller" in header


def test_the_cpp_wrapper_compiles_and_steps(tmp_path: Path) -> None:
    """The header's C++ class (``NAME_controller``) gives the C function's commands."""
    import shutil
    import subprocess

    from _c_export import compiler

    cxx = shutil.which("c++") or shutil.which("g++") or shutil.which("clang++")
    if cxx is None:
        pytest.skip("no C++ compiler (c++, g++ or clang++) on PATH")
    from neckid.export.c import write_c

    controller = _controllers()["pi"]
    write_c(controller, tmp_path, "pi")
    (tmp_path / "use.cpp").write_text(
        '#include <cstdio>\n#include "pi.h"\nint main() { pi_controller c;\n'
        '  for (int k = 0; k < 5; ++k) std::printf("%a\\n", c.step(10.0, 0.5 * k));\n'
        "  return 0; }\n"
    )
    subprocess.run([compiler(), "-O2", "-std=c99", "-c", str(tmp_path / "pi.c"), "-o",
                    str(tmp_path / "pi.o")], check=True)  # fmt: skip
    subprocess.run([cxx, "-O2", "-Wall", "-Werror", str(tmp_path / "use.cpp"),
                    str(tmp_path / "pi.o"), "-lm", "-o", str(tmp_path / "use")], check=True)  # fmt: skip
    out = subprocess.run([str(tmp_path / "use")], capture_output=True, text=True, check=True)
    controller.reset()
    want = [controller.step(10.0, 0.5 * k)[0] for k in range(5)]
    assert [float.fromhex(v) for v in out.stdout.split()] == want


def _mpc_commands(tmp_path: Path, **limits: float) -> tuple[np.ndarray, np.ndarray]:
    """An MPC on a first-order plant in ``closed_loop``, and its C export's commands on the log."""
    import glob
    import subprocess

    import control

    from _c_export import CFLAGS, compiler
    from neckid.design import linear_form
    from neckid.design.mpc import MPCController, mpc_problem
    from neckid.export.c import write_c

    problem = mpc_problem(linear_form(control.tf([0.1], [1, -0.95], dt=TS)), horizon=15, **limits)
    mpc = MPCController(problem, on_late="use")  # a simulation: no wall-clock deadline

    class Lag:
        def reset(self) -> None:
            self.y = 0.0

        def step(self, u: np.ndarray) -> list[float]:
            y, self.y = self.y, 0.95 * self.y + 0.1 * float(u[0])
            return [y]

    reference = np.repeat([1.0, -0.5, 0.7], 60)
    log = closed_loop(Lag(), mpc, reference, ts=TS)
    write_c(mpc, tmp_path, "mpc", driver=True)
    osqp = tmp_path / "mpc_osqp"
    includes = ["-I", str(osqp / "inc" / "public"), "-I", str(osqp / "inc" / "private"),
                "-I", str(osqp)]  # fmt: skip
    ours = [str(tmp_path / "mpc.c"), str(tmp_path / "mpc_main.c")]
    for source in ours:  # our code is clean C99; OSQP's generated code is compiled as it is
        subprocess.run([compiler(), *CFLAGS, *includes, "-c", source, "-o", source + ".o"],
                       check=True)  # fmt: skip
    theirs = [*sorted(glob.glob(str(osqp / "src" / "*.c"))), str(osqp / "mpc_workspace.c")]
    program = tmp_path / "run"
    subprocess.run([compiler(), "-O2", "-std=c99", *includes, *(s + ".o" for s in ours), *theirs,
                    "-lm", "-o", str(program)], check=True)  # fmt: skip
    measured = np.concatenate([[0.0], log.y[:-1, 0]])
    got = run(program, np.column_stack([reference, measured]))[:, 0]
    return got, log.u[:, 1]


def test_mpc_commands_match_closed_loop(tmp_path: Path) -> None:
    """Without output limits OSQP's generated code gives the Python solver's commands (1e-12)."""
    got, want = _mpc_commands(tmp_path)
    assert relative_error(got, want) <= 1e-12


def test_mpc_with_an_output_limit_within_the_solver_tolerance(tmp_path: Path) -> None:
    """With an output limit, within 1e-3 rad/s: OSQP's tolerance (1e-4) and its step-size
    adaptation, which the Python solver does and the embedded code (no refactoring) does not."""
    got, want = _mpc_commands(tmp_path, output_max=0.8)
    assert np.max(np.abs(got - want)) <= 1e-3
    assert np.max(np.abs(got)) <= 4.0
