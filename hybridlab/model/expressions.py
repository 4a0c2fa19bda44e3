"""Whitelisted expression language: Python ``ast`` into sympy, never ``eval``.

Model text is parsed with :func:`ast.parse` and walked node by node; only
numbers, declared names, ``+ - * / **``, unary minus, comparisons (in
relations), ``and`` (in relations) and calls of a fixed set of functions
become sympy objects. Anything else raises :class:`ExpressionError` naming
the offending token, so no model file can run code.
"""

from __future__ import annotations

import ast
import keyword
import math
import numbers
import re
import sys
import unicodedata
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import sympy as sp

from hybridlab.errors import ExpressionError
from hybridlab.model.names import spellings

__all__ = [
    "FUNCTIONS",
    "CONSTANTS",
    "RESERVED_NAMES",
    "MAX_EXPRESSION_LENGTH",
    "MAX_TREE_NODES",
    "Inequality",
    "parse_expression",
    "parse_relation",
    "check_name",
    "check_qualified_name",
    "dotted_name",
    "rename",
    "names_in",
    "as_expression",
    "expanded_size",
    "tree_size",
]

MAX_EXPRESSION_LENGTH = 10_000
_MAX_DEPTH = 200
#: Largest numerator of a rational exponent (``x**100``): larger exact powers make sympy
#: expand huge polynomials or compute huge integers. A power of two numbers whose
#: exponent has a larger numerator or denominator is computed in floating point.
_MAX_EXPONENT = 100
_MAX_INTEGER_LITERAL = int(sys.float_info.max)
#: Values sympy can produce from finite operands (``0**-1``, ``log(0)``) that are no number.
_NON_FINITE = frozenset((sp.zoo, sp.oo, sp.S.NegativeInfinity, sp.nan))


def _clip(x: sp.Expr, lo: sp.Expr, hi: sp.Expr) -> sp.Expr:
    return sp.Min(sp.Max(x, lo), hi)


#: name -> (allowed argument counts, sympy builder). ``None`` means two or more.
FUNCTIONS: Mapping[str, tuple[tuple[int, ...] | None, Callable[..., sp.Expr]]] = {
    "sin": ((1,), sp.sin),
    "cos": ((1,), sp.cos),
    "tan": ((1,), sp.tan),
    "asin": ((1,), sp.asin),
    "acos": ((1,), sp.acos),
    "atan": ((1,), sp.atan),
    "atan2": ((2,), sp.atan2),
    "sinh": ((1,), sp.sinh),
    "cosh": ((1,), sp.cosh),
    "tanh": ((1,), sp.tanh),
    "exp": ((1,), sp.exp),
    "log": ((1,), sp.log),
    "sqrt": ((1,), sp.sqrt),
    "abs": ((1,), sp.Abs),
    "sign": ((1,), sp.sign),
    "min": (None, sp.Min),
    "max": (None, sp.Max),
    "clip": ((3,), _clip),
}

#: Named constants usable in any expression.
CONSTANTS: Mapping[str, sp.Expr] = {"pi": sp.pi}

#: Names a model may not declare: functions, constants and the time symbol.
RESERVED_NAMES = frozenset(FUNCTIONS) | frozenset(CONSTANTS) | {"t"}

_BINARY = {
    ast.Add: lambda a, b: a + b,
    ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: a * b,
    ast.Div: lambda a, b: a / b,
    ast.Pow: lambda a, b: a**b,
}
_BINARY_HINT = {
    ast.BitXor: ("'^' is not a power", "^"),
    ast.Mod: ("'%' is not supported", "%"),
    ast.FloorDiv: ("'//' is not supported", "//"),
    ast.MatMult: ("'@' is not supported", "@"),
    ast.BitAnd: ("'&' is not supported; combine inequalities with 'and'", "&"),
    ast.BitOr: ("'|' is not supported", "|"),
    ast.LShift: ("'<<' is not supported", "<<"),
    ast.RShift: ("'>>' is not supported", ">>"),
}
_UNARY_TOKEN = {ast.Not: "not", ast.Invert: "~"}
_COMPARE = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">="}
_COMPARE_REJECTED = {ast.Eq: "==", ast.NotEq: "!=", ast.Is: "is", ast.IsNot: "is not",
                     ast.In: "in", ast.NotIn: "not in"}


@dataclass(frozen=True)
class Inequality:
    """One inequality normalised to ``expr >= 0`` (or ``> 0`` when strict).

    Attributes
    ----------
    expr : sympy.Expr
        The left side minus the right side, signed so that the relation holds
        when ``expr`` is non-negative.
    strict : bool
        ``True`` for ``<`` and ``>``.
    text : str
        The source text of this inequality.

    Examples
    --------
    >>> h = sp.Symbol("h", real=True)
    >>> [rel] = parse_relation("h <= 0", {"h": h})
    >>> rel.expr
    -h
    """

    expr: sp.Expr
    strict: bool
    text: str


def check_name(name: str) -> None:
    """Raise :class:`ExpressionError` unless ``name`` may be declared in a model.

    Examples (``...`` stands for the rest of the message)
    --------
    >>> check_name("m_C")
    >>> check_name("sin")
    Traceback (most recent call last):
    ...
    hybridlab.errors.ExpressionError: name shadows a built-in function or constant ...
    """
    if not isinstance(name, str) or not name.isidentifier() or keyword.iskeyword(name):
        raise ExpressionError("not a valid name (letters, digits and '_', not a keyword)",
                              str(name))
    normalised = unicodedata.normalize("NFKC", name)
    if normalised != name:
        # Python's parser NFKC-normalises identifiers, so an expression could never
        # refer to this spelling
        raise ExpressionError(f"name is not in Unicode normal form NFKC; write it as "
                              f"{normalised!r}", name)
    if name.startswith("_"):
        raise ExpressionError("names may not start with '_'", name)
    if name in RESERVED_NAMES:
        kind = "the time symbol" if name == "t" else "a built-in function or constant"
        raise ExpressionError(f"name shadows {kind}", name)


def check_qualified_name(name: str) -> None:
    """Raise :class:`ExpressionError` unless ``name`` is a name or a qualified name.

    A qualified name joins names with dots (``room1.T``): the state ``T`` of the
    component ``room1`` of a composed model. Each part is checked as :func:`check_name`.

    Examples (``...`` stands for the rest of the message)
    --------
    >>> check_qualified_name("room1.T")
    >>> check_qualified_name("room1.sin")
    Traceback (most recent call last):
    ...
    hybridlab.errors.ExpressionError: name shadows a built-in function or constant ...
    """
    if not isinstance(name, str):
        raise ExpressionError("not a valid name (letters, digits and '_', not a keyword)",
                              str(name))
    for part in name.split("."):
        try:
            check_name(part)
        except ExpressionError as exc:
            raise ExpressionError(exc.message, name) from None


def dotted_name(node: ast.AST) -> str | None:
    """The text of a chain of names joined by dots (``room1.T``), else ``None``.

    Examples
    --------
    >>> dotted_name(ast.parse("room1.T", mode="eval").body)
    'room1.T'
    >>> dotted_name(ast.parse("f(x).T", mode="eval").body) is None
    True
    """
    parts: list[str] = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    parts.append(node.id)
    return ".".join(reversed(parts))


def rename(text: str, names: Mapping[str, str]) -> str:
    """``text`` with every name that is a key of ``names`` replaced by its value.

    The names are found in the parsed tree, so a function, a longer name or a number
    that contains one is left alone; the rest of the text is kept as written.

    Raises
    ------
    ExpressionError
        If ``text`` cannot be parsed.

    Examples
    --------
    >>> rename("-a*(T - T_out) + c*(T_other - T)", {"T": "room1.T", "T_other": "room2.T"})
    '-a*(room1.T - T_out) + c*(room2.T - room1.T)'
    >>> rename("exp(-x) + x2", {"x": "tank.x", "exp": "no"})
    'exp(-tank.x) + x2'
    """
    stripped = text.strip()
    tree = _parse_tree(stripped)
    data = stripped.encode("utf-8")  # ast offsets count UTF-8 bytes
    starts = [0]
    for line in data.split(b"\n"):
        starts.append(starts[-1] + len(line) + 1)
    spans = sorted(
        (starts[node.lineno - 1] + node.col_offset,
         starts[(node.end_lineno or node.lineno) - 1] + (node.end_col_offset or 0),
         names[node.id])
        for node in ast.walk(tree)
        if isinstance(node, ast.Name) and node.id in names
        and node.id not in FUNCTIONS and node.id not in CONSTANTS)
    out, at = [], 0
    for begin, end, name in spans:
        out.append(data[at:begin])
        out.append(name.encode("utf-8"))
        at = end
    out.append(data[at:])
    return b"".join(out).decode("utf-8")


def names_in(text: str) -> set[str]:
    """The names an expression or relation text uses (functions and constants excluded).

    Examples
    --------
    >>> sorted(names_in("sin(x) + k*y <= pi"))
    ['k', 'x', 'y']
    """
    return {node.id for node in ast.walk(_parse_tree(text))
            if isinstance(node, ast.Name) and node.id not in FUNCTIONS
            and node.id not in CONSTANTS}


_STRAY_BACKSLASH = re.compile(r"\\(?!\r?\n)")


def _parse_tree(text: str) -> ast.expr:
    if not isinstance(text, str):
        raise ExpressionError("expression must be a string", repr(text)[:40])
    if len(text) > MAX_EXPRESSION_LENGTH:
        raise ExpressionError(f"expression longer than {MAX_EXPRESSION_LENGTH} characters",
                              text[:20] + "...")
    if not text.strip():
        raise ExpressionError("empty expression", text)
    stray = _STRAY_BACKSLASH.search(text)
    if stray:  # only a line continuation has a use; Python would warn about an escape
        raise ExpressionError("unexpected character '\\'", text[stray.start():][:20])
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        token = (exc.text or text).strip()
        if exc.offset:
            token = (exc.text or "")[max(exc.offset - 1, 0):].strip()[:20] or token
        raise ExpressionError(f"syntax error: {exc.msg}", token[:40]) from None
    except (ValueError, RecursionError, MemoryError):
        raise ExpressionError("expression cannot be parsed", text[:40]) from None
    return tree.body


#: Relations are expanded (``2*(x - 1)`` to ``2*x - 2``, which exposes linear guards) only
#: when the result has at most this many terms: ``(a + b + ... + h)**100`` would have
#: billions.
_MAX_EXPANDED_TERMS = 2_000


#: The most nodes a parsed expression may have as a tree, definitions substituted. A chain of
#: definitions that each use the previous one twice doubles the tree at every link while
#: the shared graph stays small; every later stage (derivatives, printing) works on trees.
MAX_TREE_NODES = 200_000


def tree_size(expr: sp.Basic, memo: dict[sp.Basic, float] | None = None) -> float:
    """The number of nodes of ``expr`` as a tree, counted in time linear in its shared graph.

    Examples
    --------
    >>> x = sp.Symbol("x")
    >>> d = x + 1
    >>> for _ in range(40):
    ...     d = sp.Function("f")(d, d)
    >>> tree_size(d) > 1e12
    True
    """
    memo = {} if memo is None else memo
    stack = [expr]
    while stack:
        node = stack[-1]
        if node in memo:
            stack.pop()
            continue
        pending = [a for a in node.args if a not in memo]
        if pending:
            stack.extend(pending)
            continue
        stack.pop()
        memo[node] = 1.0 + sum(memo[a] for a in node.args)
    return memo[expr]


def expanded_size(expr: sp.Basic, memo: dict[sp.Basic, float] | None = None) -> float:
    """An upper bound of the number of terms of ``sympy.expand(expr)``, without expanding.

    Shared subexpressions are counted once (the walk is linear in the expression's DAG).

    Examples
    --------
    >>> x, y = sp.symbols("x y")
    >>> expanded_size((x + y)**2), expanded_size((x + y) * (x - y + 1))
    (3.0, 6.0)
    >>> expanded_size((x + y + 1)**100) > 1e3
    True
    """
    memo = {} if memo is None else memo
    if expr in memo:
        return memo[expr]
    if isinstance(expr, sp.Add):
        size = float(sum(expanded_size(a, memo) for a in expr.args))
    elif isinstance(expr, sp.Mul):
        size = 1.0
        for a in expr.args:
            size *= expanded_size(a, memo)
    elif isinstance(expr, sp.Pow) and expr.exp.is_Integer and expr.exp > 1:
        k, n = expanded_size(expr.base, memo), int(expr.exp)
        size = float(math.comb(int(min(k, 1e6)) + n - 1, n)) if k < 1e6 else math.inf
    else:
        size = 1.0
    memo[expr] = min(size, math.inf)
    return memo[expr]


def _is_finite_number(atom: sp.Basic) -> bool:
    """False for zoo, oo, -oo, nan and numbers beyond the float range."""
    if atom in _NON_FINITE:
        return False
    if isinstance(atom, sp.Number):
        try:
            return math.isfinite(float(atom))
        except (OverflowError, TypeError, ValueError):
            return False
    return True


class _Builder:
    """Turns an ``ast`` expression into sympy, refusing every other node."""

    def __init__(self, text: str, symbols: Mapping[str, sp.Expr],
                 flags: frozenset[sp.Expr] = frozenset()) -> None:
        self.flags = flags
        self.text = text
        self.symbols = symbols
        self.finite: set[sp.Basic] = set()  # subexpressions already known to be finite
        self.sizes: dict[sp.Basic, float] = {}  # tree sizes of subexpressions seen

    def check_finite(self, value: sp.Expr, node: ast.AST) -> None:
        """Refuse a (sub)expression that contains a value that is no finite double.

        Operations on finite operands can still give sympy's ``zoo``, ``oo`` or ``nan``
        (``0**-1``, ``log(0)``, ``atan2(0, 0)``) or a number beyond the float range
        (``1e300*1e300``: sympy numbers have no upper limit, compiled models do).
        Subtrees checked before are skipped, so a long sum costs linear time per node.
        """
        seen: list[sp.Basic] = []
        stack: list[sp.Basic] = [value]
        while stack:
            part = stack.pop()
            if part in self.finite:
                continue
            seen.append(part)
            if part is sp.I or (part.args and all(a.is_Number or a.is_NumberSymbol
                                                  for a in part.args)
                                and part.is_extended_real is False):
                # sqrt(-1), log(-2), asin(2), (-8)**(1/3): complex constants
                raise ExpressionError("not a real number", self.token(node))
            if part.args:
                stack.extend(part.args)
            elif not _is_finite_number(part):
                message = ("number too large" if part.is_finite
                           else "expression is not a finite number")
                raise ExpressionError(message, self.token(node))
        self.finite.update(seen)

    def token(self, node: ast.AST) -> str:
        segment = ast.get_source_segment(self.text.strip(), node)
        return (segment or type(node).__name__)[:40]

    def expr(self, node: ast.AST, depth: int = 0) -> sp.Expr:
        result = self._build(node, depth)
        if isinstance(node, ast.BinOp | ast.UnaryOp | ast.Call | ast.Name | ast.Attribute):
            self.check_size(result, node)
        if isinstance(node, ast.BinOp | ast.UnaryOp | ast.Call):
            self.check_finite(result, node)
        return result

    def check_size(self, value: sp.Expr, node: ast.AST) -> None:
        """Refuse an expression whose tree (definitions substituted) is past the limit."""
        size = tree_size(value, self.sizes)
        if size > MAX_TREE_NODES:
            raise ExpressionError(f"expression too large: {size:.3g} operations with the "
                                  f"definitions substituted (at most {MAX_TREE_NODES}); "
                                  "use fewer nested definitions", self.token(node))

    def power(self, base: sp.Expr, exponent: sp.Expr, node: ast.AST) -> sp.Expr:
        """``base**exponent`` without letting sympy compute giant exact numbers."""
        rational = isinstance(exponent, sp.Rational)
        if isinstance(base, sp.Number) and isinstance(exponent, sp.Number):
            big = rational and max(abs(exponent.p), exponent.q) > _MAX_EXPONENT
            try:
                approx = complex(float(base) ** float(exponent))
            except ZeroDivisionError:
                raise ExpressionError("number is not finite", self.token(node)) from None
            except OverflowError:
                raise ExpressionError("number too large", self.token(node)) from None
            if not (math.isfinite(approx.real) and math.isfinite(approx.imag)):
                raise ExpressionError("number too large", self.token(node))
            if big:
                if approx.imag:
                    raise ExpressionError("power of a negative number is not real",
                                          self.token(node))
                return sp.Float(approx.real)
        elif rational and abs(exponent.p) > _MAX_EXPONENT:
            raise ExpressionError(f"exponent too large (at most {_MAX_EXPONENT})",
                                  self.token(node))
        try:
            return base**exponent
        except (ZeroDivisionError, OverflowError, ValueError, TypeError):
            raise ExpressionError("arithmetic on literals failed", self.token(node)) from None

    def _build(self, node: ast.AST, depth: int) -> sp.Expr:
        if depth > _MAX_DEPTH:
            raise ExpressionError("expression nested too deeply", self.token(node))
        if isinstance(node, ast.Constant):
            value = node.value
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ExpressionError("only numbers are allowed as literals", self.token(node))
            if isinstance(value, float) and not math.isfinite(value):
                raise ExpressionError("number is not finite", self.token(node))
            if isinstance(value, int) and abs(value) > _MAX_INTEGER_LITERAL:
                raise ExpressionError("number too large", self.token(node))
            return sp.Integer(value) if isinstance(value, int) else sp.Float(value)
        if isinstance(node, ast.Name):
            if node.id in self.symbols:
                return self.symbols[node.id]
            if node.id in CONSTANTS:
                return CONSTANTS[node.id]
            if node.id in FUNCTIONS:
                raise ExpressionError("function used without arguments", node.id)
            same = sorted(spellings(node.id, self.symbols))
            if len(same) > 1:  # the unqualified name of several components' variables
                raise ExpressionError(f"several components have this name; write one of: "
                                      f"{', '.join(same)}", node.id)
            raise ExpressionError("unknown symbol", node.id)
        if isinstance(node, ast.BinOp):
            op = type(node.op)
            if op in _BINARY_HINT:
                message, tok = _BINARY_HINT[op]
                if op is ast.BitXor:
                    message += "; use '**'"
                raise ExpressionError(message, tok)
            left = self.expr(node.left, depth + 1)
            right = self.expr(node.right, depth + 1)
            if op is ast.Div and right == 0:
                raise ExpressionError("division by zero", self.token(node))
            if op is ast.Pow:
                return self.power(left, right, node)
            try:
                return _BINARY[op](left, right)
            except (ZeroDivisionError, OverflowError, ValueError, TypeError):
                raise ExpressionError("arithmetic on literals failed", self.token(node)) from None
        if isinstance(node, ast.UnaryOp):
            operand = self.expr(node.operand, depth + 1)
            if isinstance(node.op, ast.USub):
                return -operand
            if isinstance(node.op, ast.UAdd):
                return operand
            raise ExpressionError("operator not allowed",
                                  _UNARY_TOKEN.get(type(node.op), self.token(node)))
        if isinstance(node, ast.Call):
            return self.call(node, depth)
        if isinstance(node, ast.Compare | ast.BoolOp):
            raise ExpressionError("a comparison is not allowed here; an expression is expected",
                                  self.token(node))
        if isinstance(node, ast.Attribute):
            # a qualified name (``room1.T``) is looked up whole: never an attribute access
            dotted = dotted_name(node)
            if dotted is not None and dotted in self.symbols:
                return self.symbols[dotted]
            if dotted is not None and any("." in name for name in self.symbols):
                raise ExpressionError("unknown symbol", dotted)
            raise ExpressionError("attribute access is not allowed", node.attr)
        if isinstance(node, ast.Subscript):
            raise ExpressionError("indexing is not allowed", self.token(node))
        if isinstance(node, ast.IfExp):
            raise ExpressionError("conditional expressions are not allowed; use min/max/sign or "
                                  "modes", self.token(node))
        raise ExpressionError(f"{type(node).__name__} is not allowed in an expression",
                              self.token(node))

    def call(self, node: ast.Call, depth: int) -> sp.Expr:
        if not isinstance(node.func, ast.Name):
            raise ExpressionError("only the built-in functions can be called",
                                  self.token(node.func))
        name = node.func.id
        if name not in FUNCTIONS:
            raise ExpressionError("unknown function", name)
        if node.keywords:
            raise ExpressionError("keyword arguments are not allowed", name)
        if any(isinstance(a, ast.Starred) for a in node.args):
            raise ExpressionError("starred arguments are not allowed", name)
        arities, builder = FUNCTIONS[name]
        n = len(node.args)
        if (arities is None and n < 2) or (arities is not None and n not in arities):
            expected = "at least 2" if arities is None else " or ".join(map(str, arities))
            raise ExpressionError(f"{name}() takes {expected} argument(s), got {n}", name)
        args = [self.expr(a, depth + 1) for a in node.args]
        try:
            return builder(*args)
        except (ValueError, TypeError, ZeroDivisionError, OverflowError):
            raise ExpressionError(f"{name}() cannot be applied to these arguments",
                                  self.token(node)) from None

    def relations(self, node: ast.AST) -> list[Inequality]:
        if isinstance(node, ast.BoolOp):
            if not isinstance(node.op, ast.And):
                raise ExpressionError("'or' is not supported; use one transition per alternative",
                                      "or")
            out: list[Inequality] = []
            for value in node.values:
                out.extend(self.relations(value))
            return out
        flag = self.flag(node)
        if flag is not None:
            return [flag]
        if not isinstance(node, ast.Compare):
            raise ExpressionError("an inequality such as 'x >= 0' is expected", self.token(node))
        operands = [node.left, *node.comparators]
        out = []
        for op, left, right in zip(node.ops, operands, operands[1:], strict=False):
            if type(op) in _COMPARE_REJECTED:
                raise ExpressionError("only inequalities (<, <=, >, >=) are allowed",
                                      _COMPARE_REJECTED[type(op)])
            lhs = self.expr(left, 1)
            rhs = self.expr(right, 1)
            symbol = _COMPARE[type(op)]
            diff = rhs - lhs if symbol in ("<", "<=") else lhs - rhs
            self.check_finite(diff, node)
            text = f"{self.token(left)} {symbol} {self.token(right)}"
            small = expanded_size(diff) <= _MAX_EXPANDED_TERMS
            out.append(Inequality(sp.expand(diff) if small and diff.is_polynomial() else diff,
                                  symbol in ("<", ">"), text))
        return out

    def flag(self, node: ast.AST) -> Inequality | None:
        """``armed`` or ``not armed`` for a boolean ``armed``: holds where its value
        (0 or 1) is above, or below, one half."""
        negated = isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not)
        operand = node.operand if isinstance(node, ast.UnaryOp) and negated else node
        name = dotted_name(operand)
        value = self.symbols.get(name) if name is not None else None
        if value is None or value not in self.flags:
            return None
        half = sp.Rational(1, 2)
        return Inequality(half - value if negated else value - half, False, self.token(node))


def parse_expression(text: str, symbols: Mapping[str, sp.Expr]) -> sp.Expr:
    """Parse ``text`` into a sympy expression over the given ``symbols``.

    Parameters
    ----------
    text : str
        The expression, e.g. ``"-e*v"``.
    symbols : mapping of str to sympy.Expr
        Every name the expression may use (states, parameters, definitions,
        ``t``). A definition may map to a whole expression.

    Returns
    -------
    sympy.Expr

    Raises
    ------
    ExpressionError
        For any text outside the whitelist, naming the offending token.

    Examples
    --------
    >>> v, e = sp.symbols("v e", real=True)
    >>> parse_expression("-e*v", {"v": v, "e": e})
    -e*v
    >>> parse_expression("__import__('os')", {})
    Traceback (most recent call last):
    ...
    hybridlab.errors.ExpressionError: unknown function (token '__import__')
    """
    return _Builder(text, symbols).expr(_parse_tree(text))


def parse_relation(text: str, symbols: Mapping[str, sp.Expr], *,
                   flags: frozenset[sp.Expr] = frozenset()) -> list[Inequality]:
    """Parse a conjunction of inequalities (``"x >= 0 and v < 0"``, ``"0 <= x <= 1"``).

    Parameters
    ----------
    text : str
        The relation text.
    symbols : mapping of str to sympy.Expr
        Names it may use.
    flags : frozenset of sympy.Expr
        The symbols of boolean variables (values 0 and 1): such a name alone is a
        relation (``armed``: its value is above one half), and so is ``not`` before it.

    Returns
    -------
    list of Inequality
        All must hold; each is normalised to ``expr >= 0``.

    Examples
    --------
    >>> x = sp.Symbol("x", real=True)
    >>> [r.expr for r in parse_relation("0 <= x <= 1", {"x": x})]
    [x, 1 - x]
    >>> parse_relation("x == 1", {"x": x})
    Traceback (most recent call last):
    ...
    hybridlab.errors.ExpressionError: only inequalities (<, <=, >, >=) are allowed (token '==')
    >>> armed = sp.Symbol("armed", real=True)
    >>> [r.expr for r in parse_relation("x >= 1 and not armed", {"x": x, "armed": armed},
    ...                                 flags=frozenset({armed}))]
    [x - 1, 1/2 - armed]
    """
    return _Builder(text, symbols, flags).relations(_parse_tree(text))


def as_expression(value: object) -> sp.Expr:
    """A sympy expression or a real number as a sympy expression; text is refused.

    Text goes through :func:`parse_expression` (the whitelist); this helper is for
    values that are already expressions, and never evaluates a string.

    Examples
    --------
    >>> x = sp.Symbol("x")
    >>> as_expression(x + 1), as_expression(2), as_expression(0.5)
    (x + 1, 2, 0.500000000000000)
    >>> as_expression("x + 1")
    Traceback (most recent call last):
    ...
    TypeError: expected a sympy expression or a real number (got str); parse text with ...
    """
    if isinstance(value, sp.Basic):
        return value
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return sp.Integer(int(value))
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return sp.Float(float(value))
    raise TypeError(f"expected a sympy expression or a real number (got {type(value).__name__}); "
                    "parse text with hybridlab.model.expressions.parse_expression")
