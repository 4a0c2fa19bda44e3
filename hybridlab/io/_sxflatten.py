"""Flattening SpaceEx networks: instantiate ``<bind>`` components and rename through ``<map>``.

A network component binds other components (base automata or networks) ``as`` instance
names and maps each of their parameters to one of its own parameters or to a number.
Flattening yields one :class:`Instance` per base automaton with, for each of its
parameters, the *global* name it stands for (a dotted path for local parameters, so
two instances never share a local variable) or the number it is fixed to.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from hybridlab.io._sxxml import BaseComponent, NetworkComponent, SpaceExError

__all__ = ["Instance", "flatten"]

_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
_MAX_INSTANCES = 200


@dataclass(frozen=True)
class Instance:
    """One base automaton of the flattened network.

    Attributes
    ----------
    name : str
        Dotted instance path (``ball_1``, ``plant.tank``); the component id at top level.
    base : BaseComponent
    vars : dict of str to str or float
        Formal real parameter -> global variable name, or the number it is fixed to.
    labels : dict of str to str
        Formal label -> global label.

    Examples
    --------
    The SpaceEx bouncing ball: ``system`` binds one ``ball`` as ``ball_1`` and fixes its
    constants ``c`` and ``g``:

    >>> import pathlib
    >>> from hybridlab.io._sxxml import read_components
    >>> components = read_components(
    ...     pathlib.Path("models/spaceex/bouncing_ball.xml").read_bytes(), "bouncing_ball.xml")
    >>> (ball,) = flatten(components, "system", "bouncing_ball.xml")
    >>> ball.name, ball.base.id, ball.vars, ball.labels
    ('ball_1', 'ball', {'x': 'x', 'v': 'v', 'c': 0.75, 'g': 1.0}, {'hop': 'hop'})
    """

    name: str
    base: BaseComponent
    vars: dict[str, str | float]
    labels: dict[str, str]


def flatten(components: dict[str, BaseComponent | NetworkComponent], system: str,
            source: str) -> list[Instance]:
    """The base automata of component ``system`` with their parameters renamed globally.

    Examples
    --------
    Two tanks of one component, each with its own (local) level ``h``, a shared inflow
    ``q`` and a fixed outflow rate ``k``:

    >>> from hybridlab.io._sxxml import read_components
    >>> doc = b'''<sspaceex>
    ... <component id="tank">
    ...   <param name="h" type="real"/><param name="q" type="real"/>
    ...   <param name="k" type="real" dynamics="const"/>
    ...   <location id="1" name="fill"><flow>h' == q - k*h</flow></location>
    ... </component>
    ... <component id="plant">
    ...   <param name="q" type="real"/>
    ...   <bind component="tank" as="t1"><map key="q">q</map><map key="k">0.1</map></bind>
    ...   <bind component="tank" as="t2"><map key="q">q</map><map key="k">0.2</map></bind>
    ... </component></sspaceex>'''
    >>> for inst in flatten(read_components(doc, "tanks.xml"), "plant", "tanks.xml"):
    ...     print(inst.name, inst.vars)
    t1 {'h': 't1.h', 'q': 'q', 'k': 0.1}
    t2 {'h': 't2.h', 'q': 'q', 'k': 0.2}
    >>> flatten(read_components(doc, "tanks.xml"), "plants", "tanks.xml")
    Traceback (most recent call last):
    ...
    hybridlab.io._sxxml.SpaceExError: tanks.xml: system: no component with this id (token 'plants')
    """
    if system not in components:
        raise SpaceExError("no component with this id", key="system", token=system,
                           source=source)
    root = components[system]
    identity: dict[str, str | float] = {p: p for p in root.params}
    out: list[Instance] = []
    _instantiate(components, root, system, identity, out, source, (system,))
    return out


def _instantiate(components: dict[str, BaseComponent | NetworkComponent],
                 comp: BaseComponent | NetworkComponent, name: str,
                 binding: dict[str, str | float], out: list[Instance], source: str,
                 stack: tuple[str, ...]) -> None:
    if len(out) > _MAX_INSTANCES:
        raise SpaceExError(f"more than {_MAX_INSTANCES} automata in the network",
                           key=comp.path, token=name, source=source)
    # parameters not bound from outside are local to this instance
    full = {p: binding.get(p, f"{name}.{p}") for p in comp.params}
    if isinstance(comp, BaseComponent):
        vars_ = {p: full[p] for p, par in comp.params.items() if par.kind == "real"}
        labels = {p: str(full[p]) for p, par in comp.params.items() if par.kind == "label"}
        out.append(Instance(name, comp, vars_, labels))
        return
    for bind in comp.binds:
        if bind.component not in components:
            raise SpaceExError("bind of an unknown component", key=bind.path + "/@component",
                               token=bind.component, source=source)
        if bind.component in stack:
            raise SpaceExError("component binds itself (directly or indirectly)",
                               key=bind.path + "/@component", token=bind.component,
                               source=source)
        child = components[bind.component]
        inner: dict[str, str | float] = {}
        for key, value in bind.maps.items():
            kpath = f"{bind.path}/map[@key='{key}']"
            if key not in child.params:
                raise SpaceExError(f"component '{bind.component}' has no parameter of this "
                                   "name", key=kpath, token=key, source=source)
            if _NUMBER.fullmatch(value):
                if child.params[key].kind == "label":
                    raise SpaceExError("a label cannot be mapped to a number", key=kpath,
                                       token=value, source=source)
                inner[key] = float(value)
            elif value in comp.params:
                if comp.params[value].kind != child.params[key].kind:
                    raise SpaceExError("a label must be mapped to a label and a variable to a "
                                       "variable", key=kpath, token=value, source=source)
                inner[key] = full[value]
            else:
                raise SpaceExError(f"not a number and not a parameter of '{comp.id}'",
                                   key=kpath, token=value, source=source)
        _instantiate(components, child, f"{name}.{bind.name}" if stack[1:] else bind.name,
                     inner, out, source, (*stack, bind.component))
