"""numba's on-disk cache, dropped when the sources it was compiled from change.

numba checks a cached function against the file that defines it only: a kernel that
inlines functions of other modules would load stale machine code after an edit of one of
them. The owners of such functions keep a digest of every source next to the cache and
drop the cached files when it no longer matches.
"""

from __future__ import annotations

import hashlib
import sys
from collections.abc import Sequence
from pathlib import Path

__all__ = ["refresh_cache", "tell"]


def refresh_cache(folder: Path, sources: Sequence[Path], stamp: str,
                  patterns: Sequence[str] = ("*.nbi", "*.nbc")) -> bool:
    """Drop the cached files ``patterns`` in ``folder`` when the digest of ``sources`` is
    not the one kept in ``folder / stamp`` (and keep the new one). Returns whether they
    were dropped; ``False`` also where the folder cannot be written (numba then does not
    cache there either).

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     source = Path(folder, "kernel.py")
    ...     _ = source.write_text("x = 1")
    ...     stale = Path(folder, "kernel.run-1.py311.nbi")
    ...     _ = stale.write_bytes(b"")
    ...     first = refresh_cache(Path(folder), [source], "kernel.sha256")
    ...     second = refresh_cache(Path(folder), [source], "kernel.sha256")
    ...     first, second, stale.exists()
    (True, False, False)
    """
    digest = hashlib.sha256(b"".join(Path(p).read_bytes() for p in sources)).hexdigest()
    kept = folder / stamp
    try:
        if kept.is_file() and kept.read_text() == digest:
            return False
        for pattern in patterns:
            for f in folder.glob(pattern):
                f.unlink(missing_ok=True)
        folder.mkdir(parents=True, exist_ok=True)
        kept.write_text(digest)
    except OSError:
        return False
    return True


def tell(message: str) -> None:
    """One line on a terminal's stderr while something slow happens, such as a first
    compile (nothing when stderr is piped or a file).

    Examples
    --------
    >>> tell("compiling: once per machine")   # a doctest's stderr is no terminal
    """
    if sys.stderr.isatty():
        print(f"hybridlab: {message} ...", file=sys.stderr, flush=True)
