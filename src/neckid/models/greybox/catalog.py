"""The grey-box structures neckid ships, and how a model file's structure name is resolved.

There is no registry a user adds to: a user's structure is passed where it is needed
(``GreyBoxODE(structure=mine)``, ``GreyBoxODE.load(path, structures=[mine])``); only the shipped
ones are found by name alone.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from types import MappingProxyType

from neckid.models.greybox.structure import GreyBoxStructure, UnknownStructureError
from neckid.models.greybox.tanks import CASCADED_TANKS

__all__ = ["SHIPPED_STRUCTURES", "resolve_structure", "shipped_structures"]

#: The shipped structures by name (read-only).
SHIPPED_STRUCTURES: Mapping[str, GreyBoxStructure] = MappingProxyType(
    {s.name: s for s in (CASCADED_TANKS,)}
)


def shipped_structures() -> Mapping[str, GreyBoxStructure]:
    """The structures neckid ships, by name (read-only): today ``"cascaded-tanks"``.

    Examples
    --------
    >>> sorted(shipped_structures())
    ['cascaded-tanks']
    """
    return SHIPPED_STRUCTURES


def resolve_structure(
    structure: str | GreyBoxStructure, given: Iterable[GreyBoxStructure] = ()
) -> GreyBoxStructure:
    """The structure called ``structure``: one of ``given``, else a shipped one.

    Parameters
    ----------
    structure : str or GreyBoxStructure
        A name, or the structure itself (returned as it is).
    given : iterable of GreyBoxStructure, default ()
        Structures passed explicitly (``GreyBoxODE.load(path, structures=[...])``); they come
        before the shipped ones of the same name.

    Raises
    ------
    UnknownStructureError
        No structure of that name (one line naming it and saying how to provide it).
    TypeError
        ``structure`` is neither a name nor a :class:`GreyBoxStructure`.
    """
    if isinstance(structure, GreyBoxStructure):
        return structure
    if not isinstance(structure, str):
        raise TypeError(
            f"structure must be a GreyBoxStructure or the name of one; got"
            f" {type(structure).__name__}"
        )
    for candidate in given:
        if not isinstance(candidate, GreyBoxStructure):
            raise TypeError(
                f"structures must hold GreyBoxStructure objects; got {type(candidate).__name__}"
            )
        if candidate.name == structure:
            return candidate
    if structure in SHIPPED_STRUCTURES:
        return SHIPPED_STRUCTURES[structure]
    raise UnknownStructureError(
        f"grey-box structure {structure!r} is not shipped with neckid (shipped:"
        f" {sorted(SHIPPED_STRUCTURES)}): pass it explicitly, GreyBoxODE.load(path,"
        f" structures=[your_structure]) with a GreyBoxStructure named {structure!r}"
    )
