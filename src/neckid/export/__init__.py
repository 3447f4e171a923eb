"""Exports of fitted models for other tools: a documented description, JSON, MATLAB files.

- :func:`export_model`: a model as a plain dictionary (method, ``ts`` [s], channels and units,
  lags, coefficients with the equation they belong to, transfer function of a linear model,
  preprocessing, training ranges); every key is described on the documentation page
  ``docs/export.md`` and is a contract (:data:`EXPORT_VERSION`);
- :func:`write_export`: that description as JSON (:func:`json_text`), as the MATLAB struct
  ``model`` of a ``.mat`` file (:func:`matlab_struct`), or a linear model as a MATLAB / Octave
  script building ``tf`` and ``idpoly`` / ``ss`` objects (:func:`matlab_script`).

``neckid export MODEL --to json|mat|tf`` is the command line's door to the same functions.
"""

from neckid.export.describe import (
    EXPORT_FORMAT,
    EXPORT_VERSION,
    LINEAR_CLASSES,
    export_model,
    is_linear,
)
from neckid.export.files import (
    EXPORT_SUFFIXES,
    MATLAB_FIELD_LENGTH,
    ExportFormat,
    json_text,
    matlab_script,
    matlab_struct,
    write_export,
)

__all__ = [
    "EXPORT_FORMAT",
    "EXPORT_SUFFIXES",
    "EXPORT_VERSION",
    "LINEAR_CLASSES",
    "MATLAB_FIELD_LENGTH",
    "ExportFormat",
    "export_model",
    "is_linear",
    "json_text",
    "matlab_script",
    "matlab_struct",
    "write_export",
]
