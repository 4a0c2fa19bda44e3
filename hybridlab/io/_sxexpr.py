"""SpaceEx constraint text -> hybridlab expression text, by tokenising (never ``eval``).

SpaceEx writes flows, guards, invariants, assignments and the ``.cfg`` sets as
conjunctions of atoms: ``x' == v & v' == -g``, ``x <= 0 & v < 0``, ``x := -c*v``,
``x == 1 & loc(ball) == always``. This module splits such text into tokens, checks every
token against a whitelist (numbers, declared names, ``+ - * / ^ ( ) ,``, comparisons,
``&``, ``'``, ``:=`` and a fixed set of functions), and re-emits each side of each atom in
hybridlab's syntax (``^`` becomes ``**``, names are renamed). Each side is then parsed by
:func:`hybridlab.model.expressions.parse_expression`, so nothing outside the whitelist can
reach sympy.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

import sympy as sp

from hybridlab.errors import ExpressionError
from hybridlab.model.expressions import MAX_EXPRESSION_LENGTH, parse_expression

__all__ = ["Atom", "Side", "SpaceExSyntaxError", "parse_conjunction", "split_disjunction",
           "tokenize"]

#: SpaceEx function names -> hybridlab function names.
FUNCTIONS = {"sin": "sin", "cos": "cos", "tan": "tan", "asin": "asin", "acos": "acos",
             "atan": "atan", "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "exp": "exp",
             "log": "log", "ln": "log", "sqrt": "sqrt", "abs": "abs", "min": "min",
             "max": "max", "pow": None}
_COMPARISONS = ("==", "=", "<=", ">=", "<", ">", ":=")
_TOKEN = re.compile(r"""
    (?P<ws>\s+)
  | (?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*)
  | (?P<op>:=|==|<=|>=|&&|[-+*/^(),&|<>=':])
""", re.VERBOSE)


class SpaceExSyntaxError(ExpressionError):
    """A SpaceEx constraint text outside the supported language (message and token).

    Examples
    --------
    >>> x = sp.Symbol("x", real=True)
    >>> try:
    ...     parse_conjunction("x <= 1 | x >= 2", {"x": "x"}, {"x": x})
    ... except SpaceExSyntaxError as exc:
    ...     print(exc, "|", exc.token)
    disjunction '|' is not supported here (token '|') | |
    >>> parse_conjunction("x <= y", {"x": "x"}, {"x": x})
    Traceback (most recent call last):
    ...
    hybridlab.io._sxexpr.SpaceExSyntaxError: unknown variable (token 'y')
    """


@dataclass(frozen=True)
class Token:
    kind: str  # "num", "name", "op"
    text: str


@dataclass(frozen=True)
class Side:
    """One side of an atom.

    Attributes
    ----------
    text : str
        The side in hybridlab syntax (``""`` for a ``loc(...)`` side).
    expr : sympy.Expr or None
        Its parsed form (``None`` for a ``loc(...)`` side and a bare location name).
    primed : str or None
        The hybridlab name of the variable when the side is exactly ``x'``.
    loc : str or None
        The argument of ``loc(...)`` when the side is one (``""`` for ``loc()``).
    bare : str or None
        The raw SpaceEx name when the side is one identifier (a location name in
        ``loc(a) == fall``).

    Examples
    --------
    >>> x, v = sp.symbols("x v", real=True)
    >>> names, symbols = {"x": "x", "v": "v"}, {"x": x, "v": v}
    >>> flow = parse_conjunction("x' == v^2", names, symbols, allow_prime=True)[0]
    >>> flow.lhs.primed, flow.rhs.text, flow.rhs.expr
    ('x', 'v**2', v**2)
    >>> where = parse_conjunction("loc(ball) == fall", names, symbols, allow_loc=True)[0]
    >>> where.lhs.loc, where.rhs.bare, where.rhs.expr
    ('ball', 'fall', None)
    """

    text: str
    expr: sp.Expr | None
    primed: str | None = None
    loc: str | None = None
    bare: str | None = None


@dataclass(frozen=True)
class Atom:
    """``lhs op rhs`` with ``op`` one of ``== <= >= < > :=`` (``=`` is read as ``==``).

    Examples
    --------
    A chain ``a <= b <= c`` gives two atoms:

    >>> x = sp.Symbol("x", real=True)
    >>> atoms = parse_conjunction("0 <= x <= 1", {"x": "x"}, {"x": x})
    >>> [(a.lhs.text, a.op, a.rhs.text) for a in atoms], atoms[1].text
    ([('0', '<=', 'x'), ('x', '<=', '1')], 'x <= 1')
    """

    lhs: Side
    op: str
    rhs: Side
    text: str


def tokenize(text: str) -> list[Token]:
    """Split SpaceEx constraint text into tokens.

    Examples
    --------
    >>> [t.text for t in tokenize("x' == -c*v^2")]
    ['x', "'", '==', '-', 'c', '*', 'v', '^', '2']
    """
    if len(text) > MAX_EXPRESSION_LENGTH:
        raise SpaceExSyntaxError(f"constraint longer than {MAX_EXPRESSION_LENGTH} characters",
                                 text[:20] + "...")
    out: list[Token] = []
    pos = 0
    while pos < len(text):
        match = _TOKEN.match(text, pos)
        if match is None:
            raise SpaceExSyntaxError("unexpected character", text[pos:pos + 20])
        kind = match.lastgroup or ""
        if kind != "ws":
            token = match.group()
            if kind == "op" and token == "&&":
                token = "&"
            out.append(Token(kind, token))
        pos = match.end()
    return out


def _split(tokens: list[Token], sep: str) -> list[list[Token]]:
    """Split at ``sep`` outside parentheses."""
    parts: list[list[Token]] = [[]]
    depth = 0
    for tok in tokens:
        if tok.text == "(":
            depth += 1
        elif tok.text == ")":
            depth -= 1
            if depth < 0:
                raise SpaceExSyntaxError("unbalanced parenthesis", ")")
        if depth == 0 and tok.kind == "op" and tok.text == sep:
            parts.append([])
        else:
            parts[-1].append(tok)
    if depth != 0:
        raise SpaceExSyntaxError("unbalanced parenthesis", "(")
    return parts


def _join(tokens: list[Token]) -> str:
    """The tokens as readable text (``x' <= -c*v``) for messages."""
    out = ""
    prev: Token | None = None
    prev_unary = False
    for tok in tokens:
        unary = tok.text in ("+", "-") and (prev is None or prev.kind == "op"
                                            and prev.text not in (")", "'"))
        glue = (prev is None or tok.text in ("'", ")", ",", "*", "/", "^")
                or prev.text in ("(", "*", "/", "^") or prev_unary
                or (tok.text == "(" and prev.kind == "name"))
        out += tok.text if glue else " " + tok.text
        prev, prev_unary = tok, unary
    return out


def split_disjunction(text: str) -> list[str]:
    """The disjuncts of ``a | b`` as texts (a SpaceEx set may be a union in the ``.cfg``).

    Examples
    --------
    >>> split_disjunction("x >= 1 | y <= 0 & z == 1")
    ['x >= 1', 'y <= 0 & z == 1']
    """
    return [_join(part) for part in _split(tokenize(text), "|")]


class _Translator:
    def __init__(self, names: Mapping[str, str], symbols: Mapping[str, sp.Expr]) -> None:
        self.names = names
        self.symbols = symbols

    def side(self, tokens: list[Token], *, allow_prime: bool) -> Side:
        if not tokens:
            raise SpaceExSyntaxError("missing operand of a comparison", "")
        if tokens[0].text == "loc" and len(tokens) >= 3 and tokens[1].text == "(":
            if tokens[-1].text != ")" or len(tokens) > 4:
                raise SpaceExSyntaxError("loc(...) takes one component name", _join(tokens))
            arg = tokens[2].text if len(tokens) == 4 else ""
            if arg and tokens[2].kind != "name":
                raise SpaceExSyntaxError("loc(...) takes one component name", _join(tokens))
            return Side("", None, loc=arg)
        if len(tokens) == 2 and tokens[0].kind == "name" and tokens[1].text == "'":
            if not allow_prime:
                raise SpaceExSyntaxError("a primed variable is not allowed here",
                                         tokens[0].text + "'")
            name = self._name(tokens[0].text)
            return Side(name, self.symbols[name], primed=name)
        bare = tokens[0].text if len(tokens) == 1 and tokens[0].kind == "name" else None
        out: list[str] = []
        for i, tok in enumerate(tokens):
            nxt = tokens[i + 1].text if i + 1 < len(tokens) else ""
            if tok.kind == "num":
                out.append(tok.text)
            elif tok.kind == "name":
                if nxt == "(":
                    out.append(self._function(tok.text))
                elif nxt == "'":
                    raise SpaceExSyntaxError("a primed variable is only allowed alone on the "
                                             "left of '==' or ':='", tok.text + "'")
                elif bare is not None and tok.text not in self.names:
                    return Side("", None, bare=bare)  # maybe a location name; caller decides
                else:
                    out.append(self._name(tok.text))
            elif tok.text == "^":
                out.append("**")
            elif tok.text in "+-*/(),":
                out.append(tok.text)
            elif tok.text == "'":
                raise SpaceExSyntaxError("a prime must follow a variable name", "'")
            else:
                raise SpaceExSyntaxError("operator not allowed in an expression", tok.text)
        text = _pretty(out)
        expr = parse_expression(text, self.symbols)
        return Side(text, expr, bare=bare)

    def _name(self, raw: str) -> str:
        if raw in self.names:
            return self.names[raw]
        if raw in FUNCTIONS:
            raise SpaceExSyntaxError("function used without arguments", raw)
        raise SpaceExSyntaxError("unknown variable", raw)

    @staticmethod
    def _function(raw: str) -> str:
        name = FUNCTIONS.get(raw)
        if name is None:
            raise SpaceExSyntaxError("unknown function", raw)
        return name


def _pretty(tokens: list[str]) -> str:
    """Join hybridlab tokens: spaces around binary ``+``/``-`` only (``-c*v + 1``)."""
    out = ""
    prev = ""
    for tok in tokens:
        unary = tok in "+-" and (not prev or prev in ("+", "-", "*", "/", "**", "(", ","))
        if tok in ("+", "-") and not unary:
            out += f" {tok} "
        elif tok == ",":
            out += ", "
        else:
            out += tok
        prev = tok
    return out


def parse_conjunction(text: str, names: Mapping[str, str], symbols: Mapping[str, sp.Expr], *,
                      allow_prime: bool = False, allow_loc: bool = False) -> list[Atom]:
    """Parse ``a & b & ...`` into atoms; ``true`` (or empty text) is the empty conjunction.

    Parameters
    ----------
    text : str
        SpaceEx constraint text.
    names : mapping of str to str
        SpaceEx name -> hybridlab name of every variable and constant in scope.
    symbols : mapping of str to sympy.Expr
        hybridlab name -> sympy symbol.
    allow_prime : bool
        Whether ``x'`` may appear (flows and assignments).
    allow_loc : bool
        Whether ``loc(component) == location`` atoms may appear (the ``.cfg`` sets).

    Examples
    --------
    >>> x, v = sp.symbols("x v", real=True)
    >>> [a.text for a in parse_conjunction("x <= 0 & v < 0", {"x": "x", "v": "v"},
    ...                                      {"x": x, "v": v})]
    ['x <= 0', 'v < 0']
    >>> parse_conjunction("x' == v^2", {"x": "x", "v": "v"}, {"x": x, "v": v},
    ...                   allow_prime=True)[0].rhs.text
    'v**2'
    """
    tokens = tokenize(text)
    if not tokens or (len(tokens) == 1 and tokens[0].text == "true"):
        return []
    translator = _Translator(names, symbols)
    atoms: list[Atom] = []
    for part in _split(tokens, "&"):
        if len(part) == 1 and part[0].text == "true":
            continue
        if any(t.text == "|" for t in part):
            raise SpaceExSyntaxError("disjunction '|' is not supported here", "|")
        if part and part[0].text == "false":
            raise SpaceExSyntaxError("'false' makes the constraint unsatisfiable", "false")
        pieces: list[list[Token]] = [[]]
        ops: list[str] = []
        depth = 0
        for tok in part:
            depth += tok.text == "("
            depth -= tok.text == ")"
            if depth == 0 and tok.kind == "op" and tok.text in _COMPARISONS:
                ops.append("==" if tok.text == "=" else tok.text)
                pieces.append([])
            else:
                pieces[-1].append(tok)
        if not ops:
            raise SpaceExSyntaxError("a comparison (==, <=, >=, <, >) is expected",
                                     _join(part)[:40])
        sides = [translator.side(p, allow_prime=allow_prime) for p in pieces]
        _check_sides(sides, ops, allow_loc)
        for op, lhs, rhs, (lt, rt) in zip(ops, sides, sides[1:],
                                          zip(pieces, pieces[1:], strict=False), strict=False):
            atoms.append(Atom(lhs, op, rhs, f"{_join(lt)} {op} {_join(rt)}"))
    return atoms


def _check_sides(sides: list[Side], ops: list[str], allow_loc: bool) -> None:
    """A ``loc(...)`` side needs ``== name``; any other unresolved name is unknown."""
    for i, side in enumerate(sides):
        if side.loc is None:
            continue
        if not allow_loc:
            raise SpaceExSyntaxError("loc(...) is only allowed in the .cfg sets", "loc")
        if len(sides) != 2 or ops[0] != "==":
            raise SpaceExSyntaxError("loc(...) must be compared with '==' to a location name",
                                     "loc")
        other = sides[1 - i]
        if other.bare is None:
            raise SpaceExSyntaxError("loc(...) must be compared with '==' to a location name",
                                     other.text or "loc")
        return
    for side in sides:
        if side.expr is None:
            raise SpaceExSyntaxError("unknown variable", side.bare or "")
