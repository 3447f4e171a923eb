"""Run pykoopman's EDMDc in its own interpreter: fit on a training record, free-run another.

This file imports NumPy and pykoopman only (it runs in the interpreter
``NECKID_PYKOOPMAN_PYTHON`` names, whose NumPy may differ from neckid's), reading an ``.npz``
of plain arrays and writing one (never pickle). Called as
``python _pykoopman_worker.py IN.npz OUT.npz`` by
:class:`neckid.experiments.benchmark.peers_koopman.PyKoopmanPeer`.

IN holds ``x_train``, ``c_train`` (the state ``x(t)`` and control ``c(t)`` rows of the training
record), ``x0`` (the ``n_delays + 1`` state rows before the run), ``c_run`` (the run's
controls), ``settings`` (JSON: ``n_delays``, ``n_centers``, ``rbf_type``, ``seed``). OUT holds
``x`` (the simulated states) or ``error`` (one line).
"""

from __future__ import annotations

import json
import sys
import warnings

import numpy as np


def main(source: str, target: str) -> None:
    """Fit, simulate, write."""
    arrays = np.load(source, allow_pickle=False)
    settings = json.loads(str(arrays["settings"]))
    try:
        x = _run(arrays, settings)
    except Exception as exc:  # reported to the caller as its error, not a traceback
        np.savez(target, error=np.array(f"{type(exc).__name__}: {exc}"))
        return
    np.savez(target, x=x)


def _run(arrays: object, settings: dict) -> np.ndarray:
    import pykoopman as pk

    x_train, c_train = arrays["x_train"], arrays["c_train"]  # type: ignore[index]
    center, scale = x_train.mean(axis=0), x_train.std(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    c_center, c_scale = c_train.mean(axis=0), c_train.std(axis=0)
    c_scale = np.where(c_scale > 0, c_scale, 1.0)
    k = int(settings["n_delays"])
    # pykoopman draws random RBF centres from NumPy's global generator: seeded here, in
    # this process only.
    np.random.seed(int(settings["seed"]))  # noqa: NPY002 - the generator pykoopman draws from
    delays = pk.observables.TimeDelay(delay=1, n_delays=k) if k else pk.observables.Identity()
    rbf = pk.observables.RadialBasisFunction(
        rbf_type=settings["rbf_type"],
        n_centers=int(settings["n_centers"]),
        centers=None,
        kernel_width=1.0,
        include_state=False,
    )
    model = pk.Koopman(observables=delays + rbf, regressor=pk.regression.EDMDc(), quiet=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit((x_train - center) / scale, u=((c_train - c_center) / c_scale)[k:])
        x0 = (arrays["x0"] - center) / scale  # type: ignore[index]
        c_run = (arrays["c_run"] - c_center) / c_scale  # type: ignore[index]
        simulated = model.simulate(x0 if k else x0[-1], c_run, n_steps=c_run.shape[0])
    return np.asarray(np.real(simulated), dtype=np.float64) * scale + center


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
