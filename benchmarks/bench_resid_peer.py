"""``neckid resid`` beside SysIdentPy's residual analysis on one data set (issue 43).

Run:  .venv/bin/python benchmarks/bench_resid_peer.py [--seeds 50] [--peer-python PATH]

SysIdentPy 0.9 caps NumPy at 2.3.5 while neckid's venv has a newer one, so the peer runs in a
venv of its own (``python -m venv /tmp/resid-peer-venv && /tmp/resid-peer-venv/bin/pip install
sysidentpy``; ``--peer-python`` or ``NECKID_PEER_PYTHON`` points at its interpreter), called
once as a subprocess on the arrays this script writes. Without it the script says why and runs
neckid's side alone.

The data: ARX(2, 2) logs (``tests/test_residuals.arx_data``: ``A = 1 - 1.5 q^-1 + 0.7 q^-2``,
``B = q^-1 + 0.5 q^-2``, white input, equation noise 0.2; 2,000 samples), one per seed. On
each, an ARX of the right order and one order too low, fitted by neckid (``LinearARX``); their
one-step residuals go through

- neckid's :func:`neckid.selection.residuals.residual_tests` (M = 25 lags, 99 %): the
  chi-square verdicts of the whiteness and independence tests;
- SysIdentPy's ``compute_residues_autocorrelation`` and ``compute_cross_correlation`` (its
  ``residues`` module, what ``plot_residues_correlation`` draws): correlations and a band
  ``±1.96 / sqrt(2N - 1)``, no statistic and no verdict. Its verdict here is the one a user reads
  off its plot: every lag 1..M inside the band (cross-correlation: lags 0..M, the only ones it
  computes).

On the first seed SysIdentPy also fits its own ARX models (FROLS, degree-1 polynomial, the same
lags, all terms) and its one-step residuals go through both analyses.

Printed: the largest difference between the two correlation estimates at lags 1..M, the bands,
and per model the share of seeds each analysis rejects.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from neckid import IOData
from neckid.metrics import residual_autocorrelation, residual_input_correlation
from neckid.models.linear import LinearARX
from neckid.regressors import Lags
from neckid.selection.residuals import residual_tests
from test_residuals import arx_data

MAX_LAG = 25
DEFAULT_PEER = "/tmp/resid-peer-venv/bin/python"

#: What runs in the peer's venv: SysIdentPy's residual correlations of every case, and its own
#: ARX fits on the first log. Reads the .npz given as argv[1], prints JSON.
PEER_SCRIPT = r"""
import json, sys
import numpy as np
import sysidentpy
from sysidentpy.residues.residues_correlation import (
    compute_cross_correlation, compute_residues_autocorrelation)
M = int(sys.argv[2])
arrays = np.load(sys.argv[1])
def analyse(y, yhat, u):
    acf, upper, _ = compute_residues_autocorrelation(y, yhat)
    ccf, cross_upper, _ = compute_cross_correlation(y, yhat, u)
    return {"acf": acf[: M + 1].tolist(), "band": float(upper),
            "ccf": ccf[: M + 1].tolist(), "cross_band": float(cross_upper)}
out = {"version": sysidentpy.__version__, "cases": {}, "fits": {}}
for key in arrays.files:
    if key.startswith("yhat_"):
        case = key[5:]
        out["cases"][case] = analyse(arrays["y_" + case], arrays[key], arrays["u_" + case])
from sysidentpy.basis_function import Polynomial
from sysidentpy.model_structure_selection import FROLS
from sysidentpy.parameter_estimation import LeastSquares
u, y = arrays["fit_u"][:, None], arrays["fit_y"][:, None]
for order in (1, 2):
    model = FROLS(order_selection=False, n_terms=2 * order, ylag=order, xlag=order,
                  basis_function=Polynomial(degree=1), estimator=LeastSquares())
    model.fit(X=u, y=y)
    yhat = model.predict(X=u, y=y, steps_ahead=1)
    out["fits"][str(order)] = {"yhat": yhat.ravel().tolist(), "max_lag": int(model.max_lag),
                               **analyse(y.ravel(), yhat.ravel(), u.ravel())}
print(json.dumps(out))
"""


def _arx(order: int, data: IOData) -> LinearARX:
    lags = list(range(1, order + 1))
    return LinearARX(Lags(outputs=lags, inputs=lags)).fit(data)


def _peer_inside(values: list[float], band: float, first: int) -> bool:
    return bool(np.all(np.abs(np.asarray(values[first:])) <= band))


def _peer_python(given: str | None) -> tuple[str | None, str]:
    """The peer's interpreter, or None and why it is not there."""
    path = given or os.environ.get("NECKID_PEER_PYTHON") or DEFAULT_PEER
    if not Path(path).exists():
        return None, f"no peer interpreter at {path} (see this script's docstring to make one)"
    check = subprocess.run(
        [path, "-c", "import sysidentpy"], capture_output=True, text=True, check=False
    )
    if check.returncode:
        return None, f"{path} cannot import sysidentpy: {check.stderr.strip().splitlines()[-1]}"
    return path, ""


def _neckid_side(seeds: int) -> tuple[dict[str, np.ndarray], dict[str, dict[str, int]], dict]:
    """Every case's arrays for the peer, neckid's rejections per model, the first cases' tests."""
    arrays: dict[str, np.ndarray] = {}
    rejected = {
        name: {"whiteness": 0, "independence": 0, "outside": 0} for name in ("right", "low")
    }
    first = {}
    for seed in range(seeds):
        data = arx_data(2000, seed)
        for name, order in (("right", 2), ("low", 1)):
            model = _arx(order, data)
            tests = residual_tests(model, data, max_lag=MAX_LAG)
            rejected[name]["whiteness"] += not tests.whiteness[0].passed
            rejected[name]["independence"] += not tests.independence[0][0].passed
            rejected[name]["outside"] += tests.whiteness[0].outside
            skip = tests.n_initial
            case = f"{name}_{seed}"
            arrays["y_" + case] = data.y[skip:, 0]
            arrays["yhat_" + case] = model.predict(data).y[skip:, 0]
            arrays["u_" + case] = data.u[skip:, 0]
            if seed == 0:
                first[name] = tests
    fit = arx_data(2000, 0)
    arrays["fit_u"], arrays["fit_y"] = fit.u[:, 0], fit.y[:, 0]
    return arrays, rejected, first


def _print_first_seed(first: dict, peer: dict) -> None:
    for name, tests in first.items():
        theirs = peer["cases"][f"{name}_0"]
        ours = tests.whiteness[0]
        gap = np.max(np.abs(np.asarray(theirs["acf"][1:]) - ours.correlation[1:]))
        cross = tests.independence[0][0]
        ours_cross = cross.correlation[MAX_LAG:]  # lags 0..M
        cross_gap = np.max(np.abs(np.asarray(theirs["ccf"]) - ours_cross))
        print(
            f"seed 0, {name} order: autocorrelation at lags 1..{MAX_LAG} differs by at most"
            f" {gap:.2e}, cross-correlation at 0..{MAX_LAG} by {cross_gap:.2e}; bands: neckid"
            f" ±{ours.bound:.4f} (99 %, z/sqrt(N)), SysIdentPy ±{theirs['band']:.4f}"
            f" (1.96/sqrt(2N-1)) and ±{theirs['cross_band']:.4f}"
        )


def _print_peer_fits(peer: dict) -> None:
    """SysIdentPy's own fits of seed 0: its plot's reading and neckid's tests of its residuals."""
    fit = arx_data(2000, 0)
    for order, values in sorted(peer["fits"].items()):
        skip = values["max_lag"]
        residual = fit.y[skip:, 0] - np.asarray(values["yhat"])[skip:]
        white = residual_autocorrelation(residual, MAX_LAG)
        independent = residual_input_correlation(residual, fit.u[skip:, 0], MAX_LAG)
        acf = "inside" if _peer_inside(values["acf"], values["band"], 1) else "OUTSIDE"
        ccf = "inside" if _peer_inside(values["ccf"], values["cross_band"], 0) else "OUTSIDE"
        print(
            f"SysIdentPy's own ARX({order}, {order}) on seed 0: its plot reads autocorrelation"
            f" {acf}, cross-correlation {ccf} its band; neckid's tests of its residuals:"
            f" whiteness {'passed' if white.passed else 'FAILED'},"
            f" independence {'passed' if independent.passed else 'FAILED'}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50)
    parser.add_argument("--peer-python", default=None)
    args = parser.parse_args()
    arrays, rejected, first = _neckid_side(args.seeds)
    for name, counts in rejected.items():
        print(
            f"neckid resid, {name} order, {args.seeds} seeds (chi-square, 99 %): whiteness rejected"
            f" {counts['whiteness']}, independence rejected {counts['independence']};"
            f" {100 * counts['outside'] / (MAX_LAG * args.seeds):.1f} % of the autocorrelation"
            " lags outside the 99 % band"
        )
    python, reason = _peer_python(args.peer_python)
    if python is None:
        print(f"SysIdentPy not run: {reason}")
        return
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "cases.npz"
        np.savez(path, **arrays)
        run = subprocess.run(
            [python, "-c", PEER_SCRIPT, str(path), str(MAX_LAG)],
            capture_output=True,
            text=True,
            check=False,
        )
    if run.returncode:
        print(f"SysIdentPy failed: {run.stderr.strip().splitlines()[-1]}")
        return
    peer = json.loads(run.stdout)
    print(f"SysIdentPy {peer['version']} in {python}")
    _print_first_seed(first, peer)
    for name in ("right", "low"):
        cases = [peer["cases"][f"{name}_{s}"] for s in range(args.seeds)]
        white = sum(not _peer_inside(c["acf"], c["band"], 1) for c in cases)
        cross = sum(not _peer_inside(c["ccf"], c["cross_band"], 0) for c in cases)
        share = np.mean([np.abs(np.asarray(c["acf"][1:])) > c["band"] for c in cases])
        print(
            f"SysIdentPy, {name} order, {args.seeds} seeds (rejected when a lag leaves its band):"
            f" autocorrelation rejected {white}, cross-correlation rejected {cross};"
            f" {100 * share:.1f} % of the autocorrelation lags outside its band"
        )
    _print_peer_fits(peer)


if __name__ == "__main__":
    main()
