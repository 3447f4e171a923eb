"""Whether the training logs can identify a state or grey-box model at all.

Set Membership and the recursive ARX warn when the data do not excite the system
persistently; a state-space or grey-box model fitted on its free-run error used to be saved
without a word when an input never moved (its response to that input is then whatever the
optimiser left) or when it had more parameters than the logs have output values (14
grey-box parameters on 8 samples). :func:`check_excitation` refuses the hopeless case and warns
on a constant input, in the words the other models use.
"""

from __future__ import annotations

import warnings
from collections.abc import Collection, Sequence

import numpy as np

from neckid.data.iodata import IOData

__all__ = ["check_excitation"]


def check_excitation(
    model: str,
    experiments: Sequence[IOData],
    *,
    n_parameters: int | None = None,
    skip: Collection[str] = (),
    stacklevel: int = 3,
    inputs: bool = True,
    n_initial: int = 0,
) -> None:
    """Refuse more parameters than output values; warn for an input constant over the logs.

    Parameters
    ----------
    model : str
        How the messages name the model (``"SubspaceStateSpace"``).
    experiments : sequence of IOData
        The training logs.
    n_parameters : int, optional
        The parameters the fit estimates (``None``: not checked).
    skip : collection of str
        Inputs that are constant by design (the experimental conditions).
    stacklevel : int, default 3
        Of the warning: the caller of ``fit``.
    n_initial : int, default 0
        Initial samples of each log the fit does not score (its lags): not counted as values.
    inputs : bool, default True
        Look at the inputs (``False``: the parameter count alone, for a model that counts its
        parameters once it has fitted them and has already looked at its inputs).

    Raises
    ------
    ValueError
        If ``n_parameters`` is at least the number of output values of the logs.

    Examples
    --------
    >>> import warnings
    >>> log = IOData(np.ones(50), np.linspace(0.0, 1.0, 50), ts=0.1, input_names=["motor"])
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     check_excitation("GreyBoxNeck", [log])
    >>> print(caught[0].message)  # doctest: +ELLIPSIS
    GreyBoxNeck: input 'motor' is constant (1) over the training logs: ... persistently ...
    """
    values = sum(max(0, d.n_samples - n_initial) for d in experiments) * experiments[0].n_outputs
    if n_parameters is not None and n_parameters >= values:
        raise ValueError(
            f"{model} has {n_parameters} parameters to fit, and the training logs give only"
            f" {values} output values: they cannot identify it; give longer logs of an"
            " experiment that excites the system persistently, or a model with fewer parameters"
        )
    if not inputs:
        return
    u = np.vstack([d.u for d in experiments])
    for j, name in enumerate(experiments[0].input_names):
        if name in skip or u.shape[0] == 0 or np.ptp(u[:, j]) > 0:
            continue
        warnings.warn(
            f"{model}: input {name!r} is constant ({float(u[0, j]):g}) over the training logs:"
            " the model's response to it is not identifiable from them (the fit follows the"
            " outputs alone). Excite the system persistently (steps, a chirp or a PRBS:"
            " neckid.signals) before trusting it.",
            RuntimeWarning,
            stacklevel=stacklevel,
        )
