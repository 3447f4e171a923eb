"""The command that hands a saved model to other tools: export (JSON, MATLAB .mat, MATLAB script, C)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from neckid.cli._app import app, console, error_console, handled

#: What ``--to`` writes, for the help text and the success line.
_WRITTEN = {
    "json": "JSON description",
    "mat": "MATLAB struct 'model'",
    "tf": "MATLAB script (tf, idpoly / ss)",
    "c": "C99 header and source",
}


@app.command()
@handled
def export(
    model_path: Path = typer.Argument(
        ...,
        metavar="MODEL",
        help="A model file written by identify (or, with --to c, a controller file written by"
        " design).",
        exists=True,
    ),
    to: str = typer.Option(
        ...,
        "--to",
        metavar="json|mat|tf|c",
        help="json: the model's description (coefficients, lags, channels, units); mat: the same"
        " as the struct 'model' of a MATLAB .mat file; tf: a MATLAB / Octave script building the"
        " transfer function (linear models: arx, rls, ss), with the model's relative and offset"
        " preprocessing as code (another step is refused unless --force); c: NAME.h and NAME.c"
        " (C99, libm only) stepping the model or controller as its simulator does.",
    ),
    out: Path = typer.Option(
        None,
        "--out",
        help="The file to write, ending in .json, .mat or .m (default: MODEL's name with that"
        " extension, beside it); with --to c the folder (created if missing; default: MODEL's"
        " name + '_c', beside it).",
        show_default=False,
    ),
    name: str = typer.Option(
        None,
        "--name",
        help="With --to c: the C name, prefix of every symbol and name of the files (default:"
        " MODEL's name, made a C identifier).",
        show_default=False,
    ),
    driver: bool = typer.Option(
        False,
        "--driver",
        help="With --to c: also write NAME_main.c, a program that runs the export on a log read"
        " from standard input (docs: 'Models as C code').",
    ),
    force: bool = typer.Option(
        False,
        "--force",
        help="Overwrite an existing output. With --to tf or c, also write the code of a model"
        " whose preprocessing (a low-pass, a resampling, ...) it cannot carry (its header says"
        " so).",
    ),
) -> None:
    """Export a saved model for MATLAB, C or other tools: its coefficients, lags, channels and units.

    Example: neckid export model.npz --to mat --out model.mat (in MATLAB: S = load('model.mat'); S.model)

    Example: neckid export model.npz --to c --out neck_c --name neck (then cc -c neck_c/neck.c)

    The keys and what each one means: the documentation page "Exporting models".
    """
    from neckid.export import EXPORT_SUFFIXES, write_export
    from neckid.export.matlab_preprocess import unwritten_steps
    from neckid.models.io import load_model
    from neckid.utils.files import check_output_file

    if to == "c":
        _export_c(model_path, out, name, driver=driver, force=force)
        return
    if name is not None or driver:
        raise ValueError(f"--name and --driver go with --to c; got --to {to}")
    if to not in EXPORT_SUFFIXES:
        raise ValueError(f"--to must be one of {', '.join([*EXPORT_SUFFIXES, 'c'])}; got {to!r}")
    suffix = EXPORT_SUFFIXES[to]
    target = out if out is not None else model_path.with_suffix(suffix)
    check_output_file(target, force=force, inputs=[model_path], option="--out", suffixes=[suffix])
    model = load_model(model_path)
    path = write_export(model, target, to=to, without_preprocessing=force)
    console.print(f"{type(model).__name__} written to {path} ({_WRITTEN[to]})", markup=False)
    missing = unwritten_steps(model) if to == "tf" else []
    if missing:  # written with --force: the script says it in its header, and so does this line
        _warn_preprocessing(path, missing)


def _warn_preprocessing(path: Path, missing: list[str]) -> None:
    error_console.print(
        f"warning: {path} does not apply the model's preprocessing {'; '.join(missing)}:"
        " apply it to the log before the model",
        markup=False,
        highlight=False,
        soft_wrap=True,
    )


def _load(model_path: Path) -> Any:
    """A model file, or a controller file (JSON) of neckid design."""
    if model_path.suffix.lower() == ".json":
        from neckid.design.files import load_controller

        return load_controller(model_path)
    from neckid.models.io import load_model

    return load_model(model_path)


def _export_c(
    model_path: Path, out: Path | None, name: str | None, *, driver: bool, force: bool
) -> None:
    """``export --to c``: the files checked (none overwritten without --force), then written."""
    from neckid.export.c import c_identifier, c_model, write_c
    from neckid.export.matlab_preprocess import unwritten_steps
    from neckid.utils.files import check_output_file

    identifier = c_identifier(name if name is not None else model_path.stem)
    folder = out if out is not None else model_path.with_name(f"{model_path.stem}_c")
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"--out {str(folder)!r} is a file; with --to c it names a folder")
    model = _load(model_path)
    code = c_model(model, without_preprocessing=force)  # refused here (one line) before any file
    companion = folder / code.companion_folder.replace("NAME_", f"{identifier}_")
    if code.companion_folder and companion.exists() and not force:
        raise ValueError(
            f"--out {str(companion)!r} exists already; use --force to overwrite it or choose"
            " another name"
        )
    folder.mkdir(parents=True, exist_ok=True)
    names = [f"{identifier}.h", f"{identifier}.c"] + ([f"{identifier}_main.c"] if driver else [])
    for file in names:
        check_output_file(
            folder / file, force=force, inputs=[model_path], option="--out", suffixes=[".h", ".c"]
        )
    paths = write_c(
        model, folder, identifier, driver=driver, force=True, without_preprocessing=force
    )
    what = type(model).__name__
    ours = ", ".join(str(p) for p in paths[: len(names)])
    solver = f"; the solver's code in {companion} ({len(paths) - len(names)} files)"
    console.print(
        f"{what} written to {ours} ({_WRITTEN['c']}{solver if code.companion_folder else ''})",
        markup=False,
    )
    missing = [] if hasattr(model, "control_law") else unwritten_steps(model)
    if missing:
        _warn_preprocessing(paths[1], missing)
