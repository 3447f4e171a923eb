r"""Set Membership with new data: what happens to the prior (ε, γ) when the data set grows.

:meth:`SetMembership.partial_fit <neckid.SetMembership.partial_fit>` adds the new regressors to
the model's data set; ε is kept (a property of the sensor and of the model class, not of how much
data was seen), γ is re-checked. The new data are consistent with the prior when the feasible set
of the grown data set is not empty, i.e. (Milanese & Novara, 2004)

.. math:: |ỹ_i − ỹ_j| \le 2ε + γ\,\|w̃_i − w̃_j\| \quad \text{for every pair,}

and the smallest γ that makes them so is γ*(ε) of the grown data set. When the prior fails,
:data:`PRIOR_RULES` say what to do: ``"adapt"`` raises γ to ``gamma_margin · γ*(ε)`` (the rule
``fit`` uses), ``"keep"`` keeps it (the bounds may then cross where the data contradict it: a
warning says so), ``"raise"`` refuses the update.

γ*(ε) of the grown set is the largest of γ*(ε) of the old set and the quotients of the pairs
that hold a new point; when the old γ*(ε) is known and the old targets did not change (no linear
part), only those pairs are computed (``n_new × n`` distances); otherwise γ*(ε) of the whole set
is computed again (:func:`~neckid.models.set_membership._kernels.tree.gamma_star`, the kd-tree branch and bound,
on the model's tree). Whether the grown set is consistent with (ε, γ) is checked first, by the
same branch and bound started at γ (:func:`~neckid.models.set_membership.training.prior_holds`).

References
----------
M. Milanese and C. Novara, "Set membership identification of nonlinear systems",
Automatica 40(6):957-975, 2004.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.models.set_membership._kernels import SMTree, gamma_star
from neckid.models.set_membership.prior import gamma_from_margin
from neckid.utils.types import FloatArray, IntArray

__all__ = ["PRIOR_RULES", "Invalidation", "PriorRule", "cross_gamma_star", "revise_prior"]


@dataclass(frozen=True)
class Invalidation:
    """Which samples of new data fall outside ``[f_l − ε, f_u + ε]`` and so falsify the prior.

    Attributes
    ----------
    outside : ndarray of bool, shape (n_samples, n_outputs)
        True where the measured output is outside the band (False in the first ``n_initial``
        rows, the initial conditions).
    excess : ndarray, shape (n_samples, n_outputs)
        How far outside the band, in output units (0 inside).
    n_initial : int
    output_names : tuple of str
    epsilon : ndarray, shape (n_outputs,)
        The noise bound ε of the band.
    """

    outside: NDArray[np.bool_]
    excess: FloatArray
    n_initial: int
    output_names: tuple[str, ...]
    epsilon: FloatArray

    @property
    def falsified(self) -> bool:
        """True if any sample of any output falsifies the prior (ε, γ, the regressor)."""
        return bool(self.outside.any())

    @property
    def fraction(self) -> FloatArray:
        """Fraction of the (non-initial) samples outside the band, per output."""
        return np.asarray(self.outside[self.n_initial :].mean(axis=0), dtype=np.float64)

    @property
    def smallest_epsilon(self) -> FloatArray:
        """The smallest ε (the Lipschitz constants kept) that puts every new sample in its band.

        A sample ``q`` is in ``[f_l − ε, f_u + ε]`` iff ``|ỹ_q − ỹ_j| <= 2ε + L_j ‖w_q − w̃_j‖``
        for every training point ``j`` (``L_j`` the constant of the pair), so the smallest such ε
        is ``ε + excess_q / 2``; the maximum over the new samples, per output (ε itself when none
        is outside). It makes the new data consistent with the training data under the prior
        with γ (and any per-point constants) as they are; pairs of new samples are not compared
        with each other. A refit at that ε derives γ*(ε) again, which can be smaller, so a
        sample may then fall outside again.
        """
        worst = self.excess[self.n_initial :].max(axis=0, initial=0.0)
        return np.asarray(self.epsilon + 0.5 * worst, dtype=np.float64)


PriorRule = Literal["adapt", "keep", "raise"]

#: What ``partial_fit`` does when new data falsify the prior (see the module docstring).
PRIOR_RULES: tuple[str, ...] = ("adapt", "keep", "raise")

#: Rows of new points per block of the cross γ* computation (a block holds ``rows × n`` distances).
_BLOCK_ROWS = 128


def cross_gamma_star(
    points: FloatArray, targets: FloatArray, new_rows: ArrayLike, epsilon: FloatArray
) -> FloatArray:
    r"""``max (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖`` over the pairs that hold a new row ``i``.

    Parameters
    ----------
    points : ndarray, shape (n, n_terms)
        Scaled regressors, old and new (in any order).
    targets : ndarray, shape (n, n_outputs)
    new_rows : array_like of int
        Indices of the new rows.
    epsilon : ndarray, shape (n_outputs,)

    Returns
    -------
    ndarray, shape (n_outputs,)
        ``inf`` where a new regressor equals another one and their targets differ by more than
        ``2ε``; 0 when there is no new point.

    Examples
    --------
    >>> import numpy as np
    >>> points = np.array([[0.0], [1.0], [3.0]])
    >>> targets = np.array([[0.0], [1.0], [5.0]])
    >>> cross_gamma_star(points, targets, [2], np.array([0.0]))  # the pair (1, 3): 4 / 2
    array([2.])
    """
    new = np.asarray(new_rows, dtype=np.int64).reshape(-1)
    n_out = targets.shape[1]
    best = np.zeros(n_out)
    for start in range(0, new.size, _BLOCK_ROWS):
        rows = new[start : start + _BLOCK_ROWS]
        difference = points[rows, None, :] - points[None, :, :]
        distance = np.sqrt(np.einsum("ijk,ijk->ij", difference, difference))
        for c in range(n_out):
            gap = np.abs(targets[rows, c, None] - targets[None, :, c]) - 2.0 * epsilon[c]
            gap[np.arange(rows.size), rows] = 0.0  # a point with itself
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(gap > 0, gap / distance, 0.0)
            best[c] = max(best[c], float(ratio.max()))
    return best


def revise_prior(
    tree: SMTree,
    new_rows: IntArray,
    epsilon: FloatArray,
    gamma: FloatArray,
    valid: NDArray[np.bool_],
    old_gamma_star: FloatArray,
    targets_changed: bool,
    prior: str,
    gamma_margin: float,
    output_names: Sequence[str],
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """γ, γ*(ε) and the validity of the prior after the data set grew (see the module docstring).

    Parameters
    ----------
    tree : SMTree
        The grown data set (scaled regressors, targets of the SM part).
    new_rows : ndarray of int
        Positions of the new rows in ``tree.points``.
    epsilon, gamma : ndarray, shape (n_outputs,)
        The prior in force.
    valid : ndarray of bool, shape (n_outputs,)
        Whether the grown data set is consistent with ``(epsilon, gamma)``, per output.
    old_gamma_star : ndarray, shape (n_outputs,)
        γ*(ε) of the old data set where known (NaN where not).
    targets_changed : bool
        The old targets changed too (a refitted linear part): γ* is recomputed over the whole set.
    prior : {"adapt", "keep", "raise"}
    gamma_margin : float
        γ = ``gamma_margin`` · γ*(ε) where ``"adapt"`` raises it.
    output_names : sequence of str

    Returns
    -------
    gamma, gamma_star, valid : ndarray
        The new γ, γ*(ε) of the grown set where computed (NaN elsewhere), and the validity.

    Raises
    ------
    ValueError
        With ``prior="raise"`` when the prior fails; with ``"adapt"`` when no γ fits (two equal
        regressors whose targets differ by more than 2ε); for an unknown ``prior``.
    """
    if prior not in PRIOR_RULES:
        raise ValueError(f"prior must be one of {list(PRIOR_RULES)}; got {prior!r}")
    incremental = not targets_changed and bool(np.all(np.isfinite(old_gamma_star)))
    star = np.full(epsilon.shape, np.nan)
    if incremental:  # exact and cheap: only the pairs with a new point
        cross = cross_gamma_star(tree.points, tree.targets, new_rows, epsilon)
        star = np.maximum(old_gamma_star, cross)
    if valid.all():
        return gamma, star, valid
    bad = np.flatnonzero(~valid)
    names = [output_names[int(c)] for c in bad]
    if prior == "raise":
        raise ValueError(
            f"the new data falsify the prior (epsilon = {epsilon[bad].tolist()}, gamma ="
            f" {gamma[bad].tolist()}) for output(s) {names}: no Lipschitz function with that"
            " constant fits the old and new data to within ±epsilon; use prior='adapt' to raise"
            " gamma, or prior='keep'"
        )
    if prior == "keep":
        warnings.warn(
            f"the new data falsify the Set Membership prior for output(s) {names}; gamma is kept"
            " (prior='keep'), so the bounds are not guaranteed where the data contradict it",
            UserWarning,
            stacklevel=4,
        )
        return gamma, star, valid
    if not incremental:
        star = np.asarray(
            gamma_star(
                tree.points, tree.targets, np.ascontiguousarray(epsilon[None, :]), tree=tree
            )[0],
            dtype=np.float64,
        )
    if not np.all(np.isfinite(star[bad])):
        c = int(bad[~np.isfinite(star[bad])][0])
        raise ValueError(
            f"output {output_names[c]!r}: two identical regressors have outputs more than"
            f" 2*epsilon = {2 * epsilon[c]:.6g} apart, so no gamma fits the data; use a larger"
            " epsilon, or prior='keep'"
        )
    revised = gamma.copy()
    revised[bad] = np.maximum(gamma[bad], gamma_from_margin(star[bad], gamma_margin))
    return revised, star, np.ones_like(valid)
