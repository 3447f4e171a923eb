"""The command that hands a saved model to other tools: export (JSON, MATLAB .mat, MATLAB script)."""

from __future__ import annotations

from pathlib import Path

import typer

from neckid.cli._app import app, console, error_console, handled

#: What ``--to`` writes, for the help text and the success line.
_WRITTEN = {
    "json": "JSON description",
    "mat": "MATLAB struct 'model'",
    "tf": "MATLAB script (tf, idpoly / ss)",
}


@app.command()
@handled
def export(
    model_path: Path = typer.Argument(
        ..., metavar="MODEL", help="A model file written by identify.", exists=True
    ),
    to: str = typer.Option(
        ...,
        "--to",
        metavar="json|mat|tf",
        help="json: the model's description (coefficients, lags, channels, units); mat: the same"
        " as the struct 'model' of a MATLAB .mat file; tf: a MATLAB / Octave script building the"
        " transfer function (linear models: arx, rls, ss), with the model's relative and offset"
        " preprocessing as code (another step is refused unless --force).",
    ),
    out: Path = typer.Option(
        None,
        "--out",
        help="The file to write, ending in .json, .mat or .m (default: MODEL's name with that"
        " extension, beside it).",
        show_default=False,
    ),
    force: bool = typer.Option(
        False,
        "--force",
        help="Overwrite an existing output. With --to tf, also write the script of a model whose"
        " preprocessing (a low-pass, a resampling, ...) it cannot carry (its header says so).",
    ),
) -> None:
    """Export a saved model for MATLAB or other tools: its coefficients, lags, channels and units.

    Example: neckid export model.npz --to mat --out model.mat (in MATLAB: S = load('model.mat'); S.model)

    The keys and what each one means: the documentation page "Exporting models".
    """
    from neckid.export import EXPORT_SUFFIXES, write_export
    from neckid.export.matlab_preprocess import unwritten_steps
    from neckid.models.io import load_model
    from neckid.utils.files import check_output_file

    if to not in EXPORT_SUFFIXES:
        raise ValueError(f"--to must be one of {', '.join(EXPORT_SUFFIXES)}; got {to!r}")
    suffix = EXPORT_SUFFIXES[to]
    target = out if out is not None else model_path.with_suffix(suffix)
    check_output_file(target, force=force, inputs=[model_path], option="--out", suffixes=[suffix])
    model = load_model(model_path)
    path = write_export(model, target, to=to, without_preprocessing=force)  # type: ignore[arg-type]
    console.print(f"{type(model).__name__} written to {path} ({_WRITTEN[to]})", markup=False)
    missing = unwritten_steps(model) if to == "tf" else []
    if missing:  # written with --force: the script says it in its header, and so does this line
        error_console.print(
            f"warning: {path} does not apply the model's preprocessing {'; '.join(missing)}:"
            " apply it to the log in MATLAB before the model",
            markup=False,
            highlight=False,
            soft_wrap=True,
        )
