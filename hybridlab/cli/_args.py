"""What the subcommands share: the parser class and parsing of values (``NAME=VALUE``, numbers).

Every error is one line naming the option (and the name, where there is one) and
the offending text: ``--set g: 'abc' is not a number``. The caller chooses the
exception class (``error``), a ``ValueError`` subclass, so that each subcommand
keeps raising its own kind (``SweepError`` for ``sweep``, ...).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from typing import NoReturn

__all__ = ["EXIT_BUG", "EXIT_FINDINGS", "EXIT_INCOMPLETE", "EXIT_INTERNAL", "EXIT_INTERRUPTED",
           "EXIT_OK", "EXIT_USAGE", "Parser", "UsageError", "assignments", "emit",
           "finite_number", "require_finite", "split_assignment"]

#: exit codes: success; an internal error; a user error (one line on stderr); a run that
#: ended early (or a verdict of UNKNOWN); ``graph --check`` findings
EXIT_OK, EXIT_INTERNAL, EXIT_USAGE, EXIT_INCOMPLETE, EXIT_FINDINGS = 0, 1, 2, 3, 4
#: the shell's code for a process ended by SIGINT; the partial result is still printed
EXIT_INTERRUPTED = 130
#: an unexpected internal error (a bug in hybridlab): sysexits' EX_SOFTWARE
EXIT_BUG = 70


class UsageError(ValueError):
    """A wrong command line: printed as one line, exit code 2.

    Examples
    --------
    >>> try:
    ...     Parser(prog="hybridlab").parse_args(["--bogus"])
    ... except UsageError as exc:
    ...     print(f"hybridlab: error: {exc}")
    hybridlab: error: unrecognized arguments: --bogus
    >>> issubclass(UsageError, ValueError)
    True
    """


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (:class:`UsageError`), not usage + message.

    Examples
    --------
    >>> parser = Parser(prog="demo")
    >>> _ = parser.add_argument("--t-end", type=float, dest="t_end")
    >>> parser.parse_args(["--t-end", "2.5"]).t_end
    2.5
    >>> parser.parse_args(["--t-end", "soon"])
    Traceback (most recent call last):
    ...
    hybridlab.cli._args.UsageError: argument --t-end: invalid float value: 'soon'
    """

    def error(self, message: str) -> NoReturn:
        raise UsageError(message)


def split_assignment(item: str, option: str, *, form: str = "NAME=VALUE",
                     require_value: bool = False,
                     error: type[Exception] = ValueError) -> tuple[str, str]:
    """Split ``NAME=VALUE`` into the stripped name and the value as written.

    Parameters
    ----------
    item : str
        One argument of ``option``.
    option : str
        The option's spelling, for the error message (``"--set"``).
    form : str
        The expected form, for the error message.
    require_value : bool
        Whether an empty value is an error too.
    error : type
        The exception class to raise.

    Examples
    --------
    >>> split_assignment(" g = 9.81", "--set")
    ('g', ' 9.81')
    >>> split_assignment("g", "--set")
    Traceback (most recent call last):
    ...
    ValueError: --set expects NAME=VALUE (got 'g')
    """
    name, sep, value = item.partition("=")
    if not sep or not name.strip() or (require_value and not value.strip()):
        raise error(f"{option} expects {form} (got {item!r})")
    return name.strip(), value


def finite_number(text: str, where: str, *, error: type[Exception] = ValueError) -> float:
    """``text`` as a finite float; ``where`` (``"--set g"``) heads the error message.

    Examples
    --------
    >>> finite_number(" 2.5", "--set g")
    2.5
    >>> finite_number("inf", "--set g")
    Traceback (most recent call last):
    ...
    ValueError: --set g: 'inf' is not a finite number
    """
    try:
        value = float(text)
    except ValueError:
        raise error(f"{where}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise error(f"{where}: {text!r} is not a finite number")
    return value


def require_finite(value: float | None, option: str, *,
                   error: type[Exception] = ValueError) -> float | None:
    """``value`` unless it is inf or nan (argparse's ``float`` accepts both); None passes.

    Examples
    --------
    >>> require_finite(None, "--t-end") is None
    True
    >>> require_finite(float("nan"), "--t-end")
    Traceback (most recent call last):
    ...
    ValueError: --t-end: nan is not a finite number
    """
    if value is not None and not math.isfinite(value):
        raise error(f"{option}: {value!r} is not a finite number")
    return value


def assignments(items: Sequence[str] | None, option: str, *,
                booleans: bool = False) -> dict[str, float | bool]:
    """``NAME=VALUE`` items as finite numbers by name; with ``booleans``, ``true`` and
    ``false`` too (the values of a bool discrete variable).

    Examples
    --------
    >>> assignments(["g=9.81", "e = 0.5"], "--set")
    {'g': 9.81, 'e': 0.5}
    >>> assignments(["armed=true", "h=2"], "--init", booleans=True)
    {'armed': True, 'h': 2.0}
    >>> assignments(["g=x"], "--set")
    Traceback (most recent call last):
    ...
    hybridlab.cli._args.UsageError: --set g: 'x' is not a number
    """
    out: dict[str, float | bool] = {}
    for item in items or ():
        name, value = split_assignment(item, option, error=UsageError)
        if booleans and value.strip() in ("true", "false"):
            out[name] = value.strip() == "true"
        else:
            out[name] = finite_number(value, f"{option} {name}", error=UsageError)
    return out


def emit(text: str, out: str | None, wrote: str | None = "") -> int:
    r"""Write ``text`` to the file ``out`` (replaced atomically) and print ``wrote {out}``
    followed by ``wrote`` (nothing when ``wrote`` is ``None``), or print ``text`` when no
    file is given; the exit code, ``EXIT_OK``.

    Examples
    --------
    >>> emit("a = 1\n", None)
    a = 1
    0
    """
    if out:
        from hybridlab._files import replace_text  # the command line starts without it

        replace_text(out, text)
        if wrote is not None:
            print(f"wrote {out}{wrote}")
    else:
        print(text, end="")
    return EXIT_OK
