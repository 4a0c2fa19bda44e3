"""The values discrete variables may take: the one rule every reader of values applies.

A discrete variable (``[discrete]`` in a model file) is ``bool`` (0 or 1), ``int``
(a whole number) or ``real``. The meaning checks apply the rule to the values a file
gives and to resets whose value is known when the model loads; a run applies it to
initial values given at call time and to every value a jump assigns.
"""

from __future__ import annotations

import math

__all__ = ["value_problem", "written"]


def value_problem(kind: str, value: float) -> str | None:
    """What is wrong with ``value`` for a discrete variable of type ``kind``, or ``None``.

    Examples
    --------
    >>> value_problem("int", 3.0) is None, value_problem("bool", True) is None
    (True, True)
    >>> value_problem("int", 2.5)
    'an int variable takes whole numbers (got 2.5)'
    >>> value_problem("bool", 2)
    'a bool variable takes 0 or 1, false or true (got 2)'
    >>> value_problem("real", True)
    'false and true are values of bool variables, not of real ones'
    """
    if isinstance(value, bool) and kind != "bool":
        return f"false and true are values of bool variables, not of {kind} ones"
    number = float(value)
    if kind == "real" or math.isnan(number):
        return None  # a value that is no number is refused where it is not finite
    if kind == "int" and not number.is_integer():
        return f"an int variable takes whole numbers (got {value!r})"
    if kind == "bool" and number not in (0.0, 1.0):
        return f"a bool variable takes 0 or 1, false or true (got {value!r})"
    return None


def written(value: object) -> str:
    """``value`` as a model file writes it, for the token of an error (``true``, ``2.5``).

    Examples
    --------
    >>> written(True), written(2.5)
    ('true', '2.5')
    """
    return str(value).lower() if isinstance(value, bool) else repr(value)
