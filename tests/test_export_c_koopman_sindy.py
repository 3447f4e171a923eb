"""C exports of the Koopman model and the sparse NARX (issues 44, 45), compiled and run.

Beyond the registry-wide test of ``test_export_c.py`` (the quick settings of each method): every
Koopman dictionary, a two-input model, the start from rest, the sparse NARX's sine and cosine
terms and its held monomials, the refusal of user functions, and both exported from a model
file by the command line with a payload condition as an input. Each is held to 1e-12 of the
run's scale against ``simulate``. Skipped without a C compiler.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from _c_export import CFLAGS, build, compiler, relative_error, run
from neckid import IOData, Lags
from neckid.export.c import c_code, c_model
from neckid.models.koopman import KoopmanEDMD
from neckid.models.sindy import SparseNARX


def _log(n: int, seed: int, inputs: int = 1) -> IOData:
    """A plant with a cubic and a product term under random staircases (``inputs`` channels)."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1.0, 1.0, size=(n // 8 + 1, inputs)), 8, axis=0)[:n]
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = (0.7 * y[t - 1] - 0.1 * y[t - 2] - 0.2 * y[t - 1] ** 3 + 0.5 * u[t - 1, 0]
                + 0.2 * u[t - 1, 0] * y[t - 1] + 0.3 * u[t - 1, inputs - 1] ** 2)  # fmt: skip
    y += 0.002 * rng.normal(size=n)
    names = [f"u{k}" for k in range(inputs)]
    return IOData(u, y, ts=0.02, input_names=names, output_names=["y"])


def _check(model: KoopmanEDMD | SparseNARX, test: IOData, folder: Path) -> float:
    out = run(build(model, folder), np.column_stack([test.u, test.y]))
    m = int(model.max_lag_)
    want = model.simulate(test).y[m:]
    assert out.shape == want.shape
    return relative_error(out, want)


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
@pytest.mark.parametrize(
    ("dictionary", "size"), [("thin-plate", 6), ("gaussian", 6), ("monomials", 9), ("gaussian", 0)]
)
def test_koopman_every_dictionary_matches_simulate(
    dictionary: str, size: int, tmp_path: Path
) -> None:
    model = KoopmanEDMD(Lags.arx(2, 2), dictionary=dictionary, n_observables=size, ridge=1e-6)
    model.fit(_log(400, 0))
    assert _check(model, _log(200, 1), tmp_path) <= 1e-12


def test_koopman_two_inputs_with_a_direct_term(tmp_path: Path) -> None:
    lags = Lags(outputs=[1, 2], inputs={"u0": [1, 2], "u1": [0, 1]})
    model = KoopmanEDMD(lags, dictionary="thin-plate", n_observables=5, ridge=1e-6)
    model.fit(_log(400, 0, inputs=2))
    assert np.any(model.D_ != 0)  # u1(t) enters the output directly
    assert _check(model, _log(200, 1, inputs=2), tmp_path) <= 1e-12
    header, _ = c_code(model, "neck")
    assert "double z[" in header and "phi5" in header and "one" in header


def test_koopman_init_is_the_simulator_at_rest(tmp_path: Path) -> None:
    """``NAME_init`` lifts a zero history, as ``simulator().reset()`` does."""
    model = KoopmanEDMD(Lags.arx(2, 2), dictionary="thin-plate", n_observables=4, ridge=1e-6)
    model.fit(_log(400, 0))
    u = _log(150, 2).u[:, 0]
    simulator = model.simulator()
    simulator.reset()
    want = np.array([simulator.step([v])[0] for v in u])
    header, source = c_code(model, "kp")
    (tmp_path / "kp.h").write_text(header)
    (tmp_path / "kp.c").write_text(source)
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include "kp.h"\nint main(void) { kp_state s; double u, y;\n'
        '  kp_init(&s);\n  while (scanf("%lf", &u) == 1) { kp_step(&s, &u, &y);'
        ' printf("%a\\n", y); }\n  return 0; }\n'
    )
    program = tmp_path / "run"
    subprocess.run([compiler(), *CFLAGS, str(tmp_path / "kp.c"), str(tmp_path / "main.c"),
                    "-lm", "-o", str(program)], check=True)  # fmt: skip
    text = "\n".join(repr(float(v)) for v in u)
    out = subprocess.run([str(program)], input=text, capture_output=True, text=True, check=True)
    got = np.array([float.fromhex(v) for v in out.stdout.split()])
    assert relative_error(got, want) <= 1e-12


@pytest.mark.filterwarnings("ignore::neckid.models.results.ExtrapolationWarning")
def test_sindy_sines_cosines_and_held_terms_match_simulate(tmp_path: Path) -> None:
    model = SparseNARX(Lags.arx(2, 2), degree=3, trigonometric=(1.0,), thresholds=(0.01,),
                       fit_for="prediction", hold_margin=0.0)  # fmt: skip
    model.fit(_log(400, 0))
    kept = model.library_.kind[np.any(model.coef_ != 0, axis=1)]
    assert {0, 1, 2} <= set(kept.tolist())  # monomials, sines and cosines are all in the map
    test = _log(200, 1)
    test = IOData(1.2 * test.u, test.y, ts=test.ts, input_names=["u0"], output_names=["y"])
    term = list(model.lags_.names).index("u0(t-1)")
    assert test.u.max() > model.hold_high_[term]  # outside the training range: terms held
    assert _check(model, test, tmp_path) <= 1e-12
    header, _ = c_code(model, "sparse")
    assert "y(t) = " in header and "sin(" in header


def test_sindy_with_user_functions_is_refused_in_one_line() -> None:
    model = SparseNARX(Lags.arx(1, 1), degree=1, functions={"tanh": np.tanh}, thresholds=(0.01,),
                       fit_for="prediction").fit(_log(300, 0))  # fmt: skip
    with pytest.raises(ValueError, match=r"user functions \(tanh\) has no C export") as caught:
        c_model(model)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("kind", ["koopman", "sindy"])
def test_cli_exports_a_model_file_with_a_payload_input(kind: str, tmp_path: Path) -> None:
    """``neckid export FILE --to c``: the loaded model, its payload condition an input column."""
    from typer.testing import CliRunner

    from neckid.cli import app
    from neckid.models.io import load_model

    def logs(seed: int, payloads: list[float]) -> list[IOData]:
        out = []
        for k, payload in enumerate(payloads):
            d = _log(300, seed + k)
            shifted = IOData(d.u, d.y + payload, ts=d.ts, input_names=["u0"], output_names=["y"])
            out.append(shifted.with_conditions(payload=payload))
        return out

    lags = Lags(outputs=[1, 2], inputs={"u0": [1, 2]}, conditions=["payload"])
    model: KoopmanEDMD | SparseNARX = (
        KoopmanEDMD(lags, n_observables=5, ridge=1e-6)
        if kind == "koopman"
        else SparseNARX(lags, degree=2, thresholds=(0.01,), fit_for="prediction")
    )
    path = tmp_path / "neck.npz"
    model.fit(logs(0, [0.0, 0.5, 1.0])).save(path)
    result = CliRunner().invoke(app, ["export", str(path), "--to", "c", "--driver"])
    assert result.exit_code == 0, result.output
    folder = tmp_path / "neck_c"
    assert "payload" in (folder / "neck.h").read_text()
    program = tmp_path / "run"
    sources = [str(folder / "neck.c"), str(folder / "neck_main.c")]
    subprocess.run([compiler(), *CFLAGS, *sources, "-lm", "-o", str(program)], check=True)
    test = logs(10, [0.7])[0]
    out = run(program, np.column_stack([test.u, np.full(test.n_samples, 0.7), test.y]))
    loaded = load_model(path)
    assert relative_error(out, loaded.simulate(test).y[loaded.max_lag_ :]) <= 1e-12
