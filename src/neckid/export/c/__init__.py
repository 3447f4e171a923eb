"""Every model, and the designed controllers, as C99 code: one header, one source, only libm.

- :func:`c_model`: the family's :class:`~neckid.export.c.program.CModel` of a fitted model
  (found through its registry entry's :attr:`~neckid.registry.Method.c_export`, a
  ``"module:function"`` text like the describer) or of a designed controller;
- :func:`c_code`: that model as ``(header, source)`` text under a C name;
- :func:`write_c`: both files (and, on request, the driver ``NAME_main.c`` of
  :mod:`neckid.export.c.driver`) written into a directory, atomically.

Each export mirrors the model's ``simulator()``: ``NAME_init``, ``NAME_reset(s, y0, u0)``,
``NAME_step(s, u, y)`` (``NAME_step_bounds`` for Set Membership), ``NAME_preprocess`` for the
preprocessing of the training logs; the header documents the state. Numbers are C99
hexadecimal literals (exact), and the arithmetic follows the Python's operation by operation.
``neckid export MODEL --to c --out DIR`` is the command line's door.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from neckid.export.c.driver import driver_source
from neckid.export.c.literals import c_identifier
from neckid.export.c.lookup import exporter_of
from neckid.export.c.preprocess import preprocess_body, preprocess_notes
from neckid.export.c.program import CModel, render

__all__ = ["CModel", "NoCExport", "c_code", "c_exportable", "c_identifier", "c_model", "write_c"]


class NoCExport(TypeError):
    """The object has no C export (a method whose registry entry names none)."""


def _is_controller(obj: Any) -> bool:
    return hasattr(obj, "control_law") and hasattr(obj, "operator")


def c_exportable() -> list[str]:
    """The registry's methods that export to C, sorted.

    Examples
    --------
    >>> "arx" in c_exportable() and "sm" in c_exportable()
    True
    """
    from neckid.registry import methods

    return sorted(name for name, method in methods().items() if method.c_export)


def c_model(obj: Any, *, without_preprocessing: bool = False) -> CModel:
    """The C export of a fitted model or a designed controller, before it is named.

    Parameters
    ----------
    obj : fitted model or DesignedController
    without_preprocessing : bool, default False
        Export a model whose preprocessing has steps C cannot carry (a low-pass filter, a
        resampling): its header then says which.

    Raises
    ------
    NoCExport
        For a model whose method has no C export (the message names the method and those
        that have one).
    ValueError
        For a model the family cannot export (a setting it does not write, preprocessing).
    """
    if _is_controller(obj):
        from neckid.export.c.controllers import c_controller

        return c_controller(obj)
    if getattr(obj, "kind", None) == "mpc" and hasattr(obj, "problem"):
        from neckid.export.c.mpc import c_mpc

        return c_mpc(obj)
    from neckid.models.base import check_is_fitted
    from neckid.registry import method_of

    exporter = exporter_of(obj)
    if exporter is None:
        method = method_of(obj)
        what = type(obj).__name__ if method is None else f"method {method.name!r}"
        raise NoCExport(
            f"{what} has no C export; the methods that have one: {', '.join(c_exportable())}"
        )
    check_is_fitted(obj)
    notes = preprocess_notes(obj, without_preprocessing)
    model = exporter(obj)
    model.notes = [*model.notes, *notes]
    model.preprocess = preprocess_body(obj)
    model.names = {
        "inputs (u, in this order)": _channels(obj, "input"),
        "outputs (y, in this order)": _channels(obj, "output"),
    }
    return model


def _channels(model: Any, kind: str) -> list[str]:
    names = list(getattr(model, f"{kind}_names_"))
    units = list(getattr(model, f"{kind}_units_", None) or [""] * len(names))
    return [f"{n} [{u}]" if u else n for n, u in zip(names, units, strict=False)]


def c_code(obj: Any, name: str = "model", **options: Any) -> tuple[str, str]:
    """``(header, source)`` of :func:`c_model` under the C name ``name``.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> u = np.random.default_rng(0).normal(size=200)
    >>> y = np.zeros(200)
    >>> for t in range(1, 200):
    ...     y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    >>> arx = LinearARX(Lags.arx(1, 1)).fit(IOData(u, y, ts=0.02))
    >>> header, source = c_code(arx, "neck")
    >>> "void neck_step(neck_state *s, const double *u, double *y);" in header
    True
    """
    return render(c_model(obj, **options), c_identifier(name))


def write_c(
    obj: Any,
    directory: str | Path,
    name: str = "model",
    *,
    driver: bool = False,
    force: bool = False,
    without_preprocessing: bool = False,
) -> list[Path]:
    """Write ``NAME.h`` and ``NAME.c`` (and ``NAME_main.c`` with ``driver``) into ``directory``.

    Parameters
    ----------
    obj : fitted model or DesignedController
    directory : str or Path
        Created if missing.
    name : str, default "model"
        The C name (made a valid identifier): the files' names and every symbol's prefix.
    driver : bool, default False
        Also write the driver of :mod:`neckid.export.c.driver`.
    force : bool, default False
        Overwrite existing files (refused otherwise, naming the first).
    without_preprocessing : bool, default False
        As :func:`c_model`.

    Returns
    -------
    list of Path
        The files written.
    """
    from neckid.utils.files import atomic_path

    model = c_model(obj, without_preprocessing=without_preprocessing)
    identifier = c_identifier(name)
    header, source = render(model, identifier)
    folder = Path(directory)
    files = {folder / f"{identifier}.h": header, folder / f"{identifier}.c": source}
    if driver:
        files[folder / f"{identifier}_main.c"] = driver_source(model, identifier)
    companion = model.companion_folder.replace("NAME_", f"{identifier}_")
    targets = [*files, *([folder / companion] if companion else [])]
    existing = [path for path in targets if path.exists()]
    if existing and not force:
        raise FileExistsError(f"{existing[0]} exists; give --force to overwrite it")
    folder.mkdir(parents=True, exist_ok=True)
    for path, text in files.items():
        with atomic_path(path) as temporary:
            temporary.write_text(text, encoding="utf-8")
    extra = [] if model.companion is None else model.companion(folder, identifier)
    return [*files, *extra]
