"""Reading SpaceEx XML (``<sspaceex>``) into plain component records, refusing DTDs.

ElementTree expands internal entities, so a "billion laughs" file could exhaust memory.
The document is therefore first scanned with expat, which stops at the first
``<!DOCTYPE``, entity declaration or external reference before anything is expanded;
only then does ElementTree build the tree.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import NoReturn
from xml.parsers import expat

from hybridlab.errors import ModelError

__all__ = ["SpaceExError", "Param", "Location", "SxTransition", "BaseComponent", "Bind",
           "NetworkComponent", "read_components"]

MAX_FILE_BYTES = 20_000_000


class SpaceExError(ModelError):
    """A SpaceEx model or configuration file cannot be imported.

    One line: ``FILE: ELEMENT-PATH: what is wrong (token 'X')``, e.g.
    ``ball.xml: component[@id='ball']/location[@name='fall']/flow: unknown variable
    (token 'vv')``.

    Examples
    --------
    >>> doc = b'''<sspaceex><component id="c"><location id="1" name="on"/>
    ...   <transition source="1" target="2"/></component></sspaceex>'''
    >>> try:
    ...     read_components(doc, "ball.xml")
    ... except SpaceExError as exc:
    ...     print(exc)
    ...     print(exc.key, exc.token)
    ball.xml: component[@id='c']/transition[1]/@target: no location has this id (token '2')
    component[@id='c']/transition[1]/@target 2
    """


@dataclass(frozen=True)
class Param:
    """A ``<param>`` of a component: a real variable or constant, or a synchronisation label.

    Examples
    --------
    >>> import pathlib
    >>> ball = read_components(pathlib.Path("models/spaceex/bouncing_ball.xml").read_bytes(),
    ...                        "bouncing_ball.xml")
    >>> ball["ball"].params["c"]
    Param(name='c', kind='real', local=False, dynamics='const',
          path="component[@id='ball']/param[@name='c']")
    >>> [p.name for p in ball["ball"].params.values() if p.kind == "label"]
    ['hop']
    """

    name: str
    kind: str  # "real" or "label"
    local: bool
    dynamics: str  # "any" or "const" (reals)
    path: str


@dataclass(frozen=True)
class Location:
    """A ``<location>`` of a base component: its invariant and flow as SpaceEx text.

    Examples
    --------
    >>> import pathlib
    >>> ball = read_components(pathlib.Path("models/spaceex/bouncing_ball.xml").read_bytes(),
    ...                        "bouncing_ball.xml")
    >>> always = ball["ball"].locations["1"]
    >>> always.name, always.invariant, always.flow
    ('always', 'x >= 0', "x' == v &\\nv' == -g")
    """

    id: str
    name: str
    invariant: str
    flow: str
    path: str


@dataclass(frozen=True)
class SxTransition:
    """A ``<transition>`` between location ids, with its label, guard and assignment text.

    Examples
    --------
    >>> import pathlib
    >>> ball = read_components(pathlib.Path("models/spaceex/bouncing_ball.xml").read_bytes(),
    ...                        "bouncing_ball.xml")
    >>> hop = ball["ball"].transitions[0]
    >>> hop.source, hop.target, hop.label, hop.guard, hop.assignment, hop.asap
    ('1', '1', 'hop', 'x <= 0 & v < 0', "v' == -c*v", False)
    """

    source: str
    target: str
    label: str
    guard: str
    assignment: str
    asap: bool
    path: str


@dataclass(frozen=True)
class BaseComponent:
    """A component with locations: one automaton (locations by id).

    Examples
    --------
    >>> import pathlib
    >>> ball = read_components(pathlib.Path("models/spaceex/bouncing_ball.xml").read_bytes(),
    ...                        "bouncing_ball.xml")
    >>> base = ball["ball"]
    >>> base.id, list(base.params), [loc.name for loc in base.locations.values()]
    ('ball', ['x', 'v', 'c', 'g', 'hop'], ['always'])
    >>> len(base.transitions), base.path
    (1, "component[@id='ball']")
    """

    id: str
    params: dict[str, Param]
    locations: dict[str, Location]  # by id
    transitions: list[SxTransition]
    path: str


@dataclass(frozen=True)
class Bind:
    """A ``<bind>`` of a network: an instance ``name`` of ``component``, its parameters
    mapped to the network's parameters or to numbers (``maps``, as text).

    Examples
    --------
    >>> import pathlib
    >>> ball = read_components(pathlib.Path("models/spaceex/bouncing_ball.xml").read_bytes(),
    ...                        "bouncing_ball.xml")
    >>> bind = ball["system"].binds[0]
    >>> bind.component, bind.name, bind.maps
    ('ball', 'ball_1', {'x': 'x', 'v': 'v', 'c': '0.75', 'g': '1', 'hop': 'hop'})
    """

    component: str
    name: str  # the ``as`` attribute
    maps: dict[str, str]
    path: str


@dataclass(frozen=True)
class NetworkComponent:
    """A component with binds: a network of instances of other components.

    Examples
    --------
    >>> import pathlib
    >>> ball = read_components(pathlib.Path("models/spaceex/bouncing_ball.xml").read_bytes(),
    ...                        "bouncing_ball.xml")
    >>> system = ball["system"]
    >>> system.id, list(system.params), [b.name for b in system.binds]
    ('system', ['x', 'v', 'hop'], ['ball_1'])
    """

    id: str
    params: dict[str, Param]
    binds: list[Bind] = field(default_factory=list)
    path: str = ""


def _fail(source: str, key: str, message: str, token: str = "") -> NoReturn:
    raise SpaceExError(message, key=key, token=token, source=source)


def _refuse_dtd(data: bytes, source: str) -> None:
    """Scan with expat and refuse any DTD, entity declaration or external entity."""

    class _Refused(Exception):
        pass

    def refuse(what: str) -> NoReturn:
        raise _Refused(what)

    parser = expat.ParserCreate()
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    parser.StartDoctypeDeclHandler = lambda *a: refuse("<!DOCTYPE")
    parser.EntityDeclHandler = lambda *a: refuse("<!ENTITY")
    parser.UnparsedEntityDeclHandler = lambda *a: refuse("<!ENTITY")
    parser.ExternalEntityRefHandler = lambda *a: refuse("external entity")
    try:
        parser.Parse(data, True)
    except _Refused as exc:
        _fail(source, "sspaceex", "DTDs and entity declarations are not allowed in SpaceEx "
              "files", str(exc))
    except expat.ExpatError as exc:
        _fail(source, "sspaceex", f"invalid XML: {expat.ErrorString(exc.code)} "
              f"(at line {exc.lineno}, column {exc.offset + 1})")


def _tag(element: ET.Element) -> str:
    return element.tag.rpartition("}")[2]


def _text(element: ET.Element, child: str) -> str:
    parts = [(c.text or "") for c in element if _tag(c) == child]
    return " & ".join(p.strip() for p in parts if p.strip())


def _attr(element: ET.Element, name: str, source: str, path: str) -> str:
    value = element.get(name)
    if value is None or not value.strip():
        _fail(source, path, f"missing attribute '{name}'", _tag(element))
    return value.strip()


def _params(element: ET.Element, source: str, path: str) -> dict[str, Param]:
    params: dict[str, Param] = {}
    for p in element:
        if _tag(p) != "param":
            continue
        name = _attr(p, "name", source, f"{path}/param")
        ppath = f"{path}/param[@name='{name}']"
        kind = (p.get("type") or "real").strip()
        if kind not in ("real", "label"):
            _fail(source, ppath + "/@type", "parameter type must be 'real' or 'label'", kind)
        dynamics = (p.get("dynamics") or "any").strip()
        if kind == "real" and dynamics not in ("any", "const"):
            _fail(source, ppath + "/@dynamics", "dynamics must be 'any' or 'const'", dynamics)
        for dim in ("d1", "d2"):
            if (p.get(dim) or "1").strip() != "1":
                _fail(source, ppath + f"/@{dim}", "only scalar parameters are supported",
                      p.get(dim) or "")
        if name in params:
            _fail(source, ppath, "parameter declared twice", name)
        local = (p.get("local") or "false").strip().lower() == "true"
        params[name] = Param(name, kind, local, dynamics, ppath)
    return params


def _base(element: ET.Element, cid: str, source: str, path: str) -> BaseComponent:
    params = _params(element, source, path)
    locations: dict[str, Location] = {}
    names: set[str] = set()
    for loc in element:
        if _tag(loc) != "location":
            continue
        lid = _attr(loc, "id", source, f"{path}/location")
        name = (loc.get("name") or f"loc{lid}").strip()
        lpath = f"{path}/location[@name='{name}']"
        if lid in locations:
            _fail(source, lpath + "/@id", "location id used twice", lid)
        if name in names:
            _fail(source, lpath + "/@name", "location name used twice", name)
        names.add(name)
        locations[lid] = Location(lid, name, _text(loc, "invariant"), _text(loc, "flow"), lpath)
    transitions = []
    for k, tr in enumerate(t for t in element if _tag(t) == "transition"):
        tpath = f"{path}/transition[{k + 1}]"
        src = _attr(tr, "source", source, tpath)
        dst = _attr(tr, "target", source, tpath)
        for attr, value in (("source", src), ("target", dst)):
            if value not in locations:
                _fail(source, f"{tpath}/@{attr}", "no location has this id", value)
        label = _text(tr, "label")
        if label and label not in params:
            _fail(source, tpath + "/label", "label is not declared as a parameter", label)
        if label and params[label].kind != "label":
            _fail(source, tpath + "/label", "a transition label must be a label parameter",
                  label)
        asap = (tr.get("asap") or "false").strip().lower() == "true"
        transitions.append(SxTransition(src, dst, label, _text(tr, "guard"),
                                        _text(tr, "assignment"), asap, tpath))
    if not locations:
        _fail(source, path, "a base component needs at least one location", cid)
    return BaseComponent(cid, params, locations, transitions, path)


def _network(element: ET.Element, cid: str, source: str, path: str) -> NetworkComponent:
    binds = []
    for b in element:
        if _tag(b) != "bind":
            continue
        comp = _attr(b, "component", source, f"{path}/bind")
        name = _attr(b, "as", source, f"{path}/bind[@component='{comp}']")
        bpath = f"{path}/bind[@as='{name}']"
        maps: dict[str, str] = {}
        for m in b:
            if _tag(m) != "map":
                continue
            key = _attr(m, "key", source, bpath + "/map")
            if key in maps:
                _fail(source, f"{bpath}/map[@key='{key}']", "parameter mapped twice", key)
            value = (m.text or "").strip()
            if not value:
                _fail(source, f"{bpath}/map[@key='{key}']", "empty map", key)
            maps[key] = value
        binds.append(Bind(comp, name, maps, bpath))
    return NetworkComponent(cid, _params(element, source, path), binds, path)


def read_components(data: bytes, source: str) -> dict[str, BaseComponent | NetworkComponent]:
    """Parse a SpaceEx XML document into its components, in file order.

    Examples
    --------
    >>> doc = b'''<sspaceex version="0.2"><component id="c">
    ...   <param name="x" type="real" local="false" d1="1" d2="1" dynamics="any"/>
    ...   <location id="1" name="on"><flow>x' == 1</flow></location>
    ... </component></sspaceex>'''
    >>> read_components(doc, "c.xml")["c"].locations["1"].flow
    "x' == 1"
    """
    if len(data) > MAX_FILE_BYTES:
        _fail(source, "sspaceex", f"file larger than {MAX_FILE_BYTES} bytes")
    _refuse_dtd(data, source)
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:  # pragma: no cover - expat accepted it already
        _fail(source, "sspaceex", f"invalid XML: {exc}")
    if _tag(root) != "sspaceex":
        _fail(source, _tag(root), "the root element must be <sspaceex>", _tag(root))
    components: dict[str, BaseComponent | NetworkComponent] = {}
    for element in root:
        if _tag(element) != "component":
            continue
        cid = _attr(element, "id", source, "component")
        path = f"component[@id='{cid}']"
        if cid in components:
            _fail(source, path, "component id used twice", cid)
        has_bind = any(_tag(c) == "bind" for c in element)
        has_loc = any(_tag(c) == "location" for c in element)
        if has_bind and has_loc:
            _fail(source, path, "a component has either locations or binds, not both", cid)
        components[cid] = (_network(element, cid, source, path) if has_bind
                           else _base(element, cid, source, path))
    if not components:
        _fail(source, "sspaceex", "no <component> in the file")
    return components
