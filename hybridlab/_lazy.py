"""Public names of a package that load on first use (PEP 562).

A package's ``__init__.py`` lists its public names once, as imports under
``if TYPE_CHECKING:``; type checkers and readers see ordinary imports, and at run
time :func:`lazy_exports` reads the same block and imports each name's module on
first access. ``import hybridlab`` therefore costs nothing but this module, and
``hybridlab --help`` does not load numpy, scipy or sympy.
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["lazy_exports", "type_checking_imports"]


def type_checking_imports(source: str) -> dict[str, tuple[str, str]]:
    """The names imported under ``if TYPE_CHECKING:`` in ``source``.

    Parameters
    ----------
    source : str
        The text of a module.

    Returns
    -------
    dict
        Each bound name to ``(module, attribute)``; only absolute ``from ... import``
        statements are read.

    Examples
    --------
    >>> text = "if TYPE_CHECKING:\\n    from a.b import c, d as e\\n"
    >>> type_checking_imports(text)
    {'c': ('a.b', 'c'), 'e': ('a.b', 'd')}
    """
    import ast  # read on the first lookup of a lazy name, not on import

    names: dict[str, tuple[str, str]] = {}
    for node in ast.parse(source).body:
        if not (isinstance(node, ast.If) and isinstance(node.test, ast.Name)
                and node.test.id == "TYPE_CHECKING"):
            continue
        for statement in node.body:
            if isinstance(statement, ast.ImportFrom) and statement.module and not statement.level:
                for alias in statement.names:
                    names[alias.asname or alias.name] = (statement.module, alias.name)
    return names


def lazy_exports(package: str, init_file: str) -> tuple[Callable[[str], Any],
                                                         Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for a package whose public names load on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    init_file : str
        Its ``__file__``; the ``if TYPE_CHECKING:`` imports in it are the exports.
        Submodules load on first access too (``hybridlab.model.loads_model``).

    Returns
    -------
    tuple
        The module-level ``__getattr__`` and ``__dir__`` (PEP 562). A name, once
        loaded, is stored in the package, so later lookups are plain attribute reads.

    Examples
    --------
    >>> import hybridlab
    >>> hybridlab.Status.COMPLETED.name
    'COMPLETED'
    >>> "simulate" in dir(hybridlab)
    True
    >>> hybridlab.model.loads_model is hybridlab.loads_model
    True
    """
    @functools.cache
    def origins() -> dict[str, tuple[str, str]]:  # the file is read on the first lookup
        return type_checking_imports(Path(init_file).read_text(encoding="utf-8"))

    def __getattr__(name: str) -> Any:
        if name in origins():
            module, attribute = origins()[name]
            value = getattr(importlib.import_module(module), attribute)
        elif importlib.util.find_spec(f"{package}.{name}") is not None:
            value = importlib.import_module(f"{package}.{name}")  # a subpackage or module
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(origins()))

    return __getattr__, __dir__
