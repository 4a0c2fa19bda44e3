"""Qualified names and product modes: the names a composed model is written in.

A model built from components (``[instances]``, see ``docs/model-format.md``) names
each component's variables ``instance.name`` (``room1.T``) and each mode of the product
``instance.mode|instance.mode|...`` (``room1.on|room2.off|heater.idle``), components in
declaration order. The rules here are read by the meaning checks and by the places that
take names from users (calls, the command line, safety specs):

- a qualified name whose last part is unique in the model may also be written without
  its qualifier (:func:`aliases`), and so may a component's mode in a
  pattern of product modes (:func:`match_modes`);
- a transition's ``source`` may name some components' modes only
  (``"room1.off|heater.idle"`` stands for every product mode with those parts), and its
  ``target`` names the components that change (:func:`mode_target`).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence

__all__ = ["SEPARATOR", "aliases", "match_modes", "mode_parts", "mode_target", "spellings"]

#: Joins the components' modes in the name of a product mode.
SEPARATOR = "|"


def aliases(names: Iterable[str]) -> dict[str, str]:
    """Unqualified spellings of the qualified ``names`` that are unique, to their names.

    ``room1.a`` is also ``a`` when no other qualified name ends in ``.a`` and ``a``
    itself is not declared.

    Examples
    --------
    >>> aliases(["room1.T", "room2.T", "room1.a", "heater.P", "P"])
    {'a': 'room1.a'}
    >>> aliases(["x", "v"])
    {}
    """
    names = list(dict.fromkeys(names))
    declared = set(names)
    last = Counter(name.rsplit(".", 1)[1] for name in names if "." in name)
    return {name.rsplit(".", 1)[1]: name for name in names
            if "." in name and last[name.rsplit(".", 1)[1]] == 1
            and name.rsplit(".", 1)[1] not in declared}


def spellings(name: str, names: Iterable[str]) -> list[str]:
    """The qualified ``names`` that ``name`` could mean unqualified (in ``names``' order).

    More than one: ``name`` is shared by several components and must be qualified.

    Examples
    --------
    >>> spellings("T", ["room1.T", "room2.T", "heater.P"])
    ['room1.T', 'room2.T']
    """
    return [n for n in names if n.endswith(f".{name}")]


def mode_parts(mode: str) -> dict[str, str]:
    """The components' modes of a product mode name, by instance.

    Examples
    --------
    >>> mode_parts("room1.on|heater.idle")
    {'room1': 'room1.on', 'heater': 'heater.idle'}
    >>> mode_parts("fall")
    {'fall': 'fall'}
    """
    return {part.split(".", 1)[0]: part for part in mode.split(SEPARATOR)}


def match_modes(pattern: str, modes: Sequence[str]) -> list[str]:
    """The modes that ``pattern`` stands for: itself if it is a mode, else every product
    mode that has each of its parts.

    A part may leave out its instance when its name is the mode of one component only
    (``hold`` for ``logic.hold``), as a unique variable name may (:func:`aliases`).

    Examples
    --------
    >>> modes = ["a.on|b.on", "a.on|b.off", "a.off|b.on", "a.off|b.off"]
    >>> match_modes("a.on", modes), match_modes("b.off|a.off", modes)
    (['a.on|b.on', 'a.on|b.off'], ['a.off|b.off'])
    >>> match_modes("fall", ["fall"]), match_modes("rise", ["fall"])
    (['fall'], [])
    >>> match_modes("hold", ["a.run|b.hold", "a.run|b.move"])
    ['a.run|b.hold']
    >>> match_modes("on", modes)  # a mode of both components: qualify it
    []
    """
    if pattern in modes:
        return [pattern]
    parts = {part for mode in modes for part in mode.split(SEPARATOR) if "." in part}
    wanted = set()
    for part in pattern.split(SEPARATOR):
        same = [part] if part in parts else spellings(part, sorted(parts))
        if len(same) != 1:
            return []
        wanted.add(same[0])
    return [mode for mode in modes if wanted <= set(mode.split(SEPARATOR))]


def mode_target(source: str, target: str) -> str:
    """The mode a transition from ``source`` enters: ``"*"`` is ``source`` itself, a mode
    name is that mode, and the parts of a product target replace the source's parts of
    the same components.

    Examples
    --------
    >>> mode_target("a.on|b.off", "b.on"), mode_target("a.on|b.off", "*")
    ('a.on|b.on', 'a.on|b.off')
    >>> mode_target("fall", "rise")
    'rise'
    >>> mode_target("a|b", "a|b")  # a mode of a flat model whose name has the separator
    'a|b'
    """
    if target == "*":
        return source
    parts = mode_parts(source)
    changes = mode_parts(target)
    product = all("." in part for part in source.split(SEPARATOR))
    if SEPARATOR not in source or not product or not changes.keys() <= parts.keys():
        return target
    parts.update(changes)
    return SEPARATOR.join(parts.values())
