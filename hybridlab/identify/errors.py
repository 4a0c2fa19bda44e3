"""Errors of the identification layer."""

from __future__ import annotations

from hybridlab.errors import HybridlabError

__all__ = ["DataError", "TargetError"]


class DataError(HybridlabError, ValueError):
    """Measured data cannot be used for an identification.

    The message names the offending column (or argument) and what is wrong.

    Parameters
    ----------
    message : str
        What is wrong, in one sentence.
    column : str, optional
        The column or argument concerned, such as ``velocity``.
    source : str, optional
        The file the data came from.

    Examples
    --------
    >>> str(DataError("contains NaN at row 3", column="force", source="runs.csv"))
    "runs.csv: column 'force': contains NaN at row 3"
    """

    def __init__(self, message: str, *, column: str = "", source: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.column = column
        self.source = source

    def __str__(self) -> str:
        parts = [self.source] if self.source else []
        if self.column:
            parts.append(f"column {self.column!r}")
        return ": ".join([*parts, self.message])


class TargetError(HybridlabError, ValueError):
    """A target of :func:`hybridlab.identify.fit_targets` is malformed.

    Parameters
    ----------
    message : str
        What is wrong, in one sentence.
    key : str, optional
        Where: ``targets[2].tolerance``.
    source : str, optional
        The file the targets came from.

    Examples
    --------
    >>> str(TargetError("must be positive (got 0)", key="targets[2].tolerance",
    ...                 source="targets.toml"))
    'targets.toml: targets[2].tolerance: must be positive (got 0)'
    """

    def __init__(self, message: str, *, key: str = "", source: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.key = key
        self.source = source

    def __str__(self) -> str:
        return ": ".join([p for p in (self.source, self.key) if p] + [self.message])
