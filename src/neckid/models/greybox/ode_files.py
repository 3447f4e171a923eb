"""Loading a GreyBoxODE whose structure the caller passes: ``GreyBoxODE.load(path, structures=...)``.

A model file holds the structure's *name* and fingerprint, never its functions (no pickle):
:func:`neckid.load_model` finds the shipped structures by name, and a user's structure comes
from the caller. This module runs the checks :func:`neckid.models.io.load_model` runs (the
file's format, the rebuilt model's values, a short free run of zeros, the kind of every entry),
with the structures handed to :meth:`GreyBoxODE._from_state`.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np

from neckid.models.greybox.structure import GreyBoxStructure
from neckid.models.io import read_model_file
from neckid.models.io_checks import check_array_kinds

__all__ = ["load_with_structures"]


def load_with_structures(
    cls: Any, path: str | Path, structures: tuple[GreyBoxStructure, ...]
) -> Any:
    """The model in ``path``, its structure found among ``structures`` (then the shipped ones).

    Raises
    ------
    TypeError
        If the file holds another model class.
    ValueError
        As :func:`neckid.load_model`, naming the file.
    """
    class_name, arrays, meta = read_model_file(path)
    if class_name != cls.__name__:
        raise TypeError(f"{path} holds a {class_name}, not a {cls.__name__}")
    try:
        with np.errstate(all="ignore"):
            model = cls._from_state(arrays, meta, structures)
            model._check_state()
            with warnings.catch_warnings():
                # Zeros may lie outside the training range: that warning says nothing here.
                warnings.simplefilter("ignore")
                model.simulate(model._zeros(3))
            if "preprocessing" in meta:
                from neckid.data.preprocess import Pipeline

                model.preprocessing_ = Pipeline.from_list(meta["preprocessing"])
            if "channel_map" in meta:
                from neckid.models.io import check_channel_map

                model.channel_map_ = check_channel_map(meta["channel_map"])
            written = model._get_state()[0]
    except KeyError as exc:
        raise ValueError(
            f"{path}: this {class_name} file has no {exc.args[0]!r} entry; it is damaged or was"
            " not written by neckid"
        ) from None
    except (TypeError, ValueError, IndexError, OverflowError, AttributeError) as exc:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise ValueError(f"{path}: invalid {class_name} file: {reason}") from exc
    check_array_kinds(Path(path), class_name, arrays, written)
    return model
