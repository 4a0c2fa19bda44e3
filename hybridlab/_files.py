"""Output files replaced atomically: a failed write never costs the user the old file.

Every file hybridlab writes for a user (results, tables, reports, figures, DOT text,
schemas, imported models) goes through :func:`replace_file`: the content is written to
a temporary file in the target's folder, flushed to disk, and only then renamed over the
target (``os.replace``, atomic on POSIX and Windows). A full disk, a killed process or
an exception while writing leaves the old file exactly as it was and no partial file
behind. The new file gets the old file's permissions, or the ordinary ones (``0o666``
less the umask) when there was none.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

__all__ = ["MAX_INPUT_BYTES", "read_bounded", "replace_file", "replace_text", "replaced"]

#: The largest input file read (model, SpaceEx, cfg, CSV, targets): 64 MiB. Every reader
#: stops there, so ``/dev/zero`` or a huge file is an error, not an endless read.
MAX_INPUT_BYTES = 64 * 1024 * 1024


def read_bounded(path: str | Path, limit: int = MAX_INPUT_BYTES) -> bytes:
    """The bytes of ``path``, at most ``limit`` of them.

    Raises
    ------
    OSError
        As ``open`` does, and with ``errno.EFBIG`` when the file holds more than
        ``limit`` bytes (a device such as ``/dev/zero`` included).

    Examples
    --------
    >>> read_bounded("/dev/zero", limit=1000)
    Traceback (most recent call last):
    ...
    OSError: [Errno 27] larger than 1000 bytes: '/dev/zero'
    """
    with open(path, "rb") as fh:
        data = fh.read(limit + 1)
    if len(data) > limit:
        raise OSError(errno.EFBIG, f"larger than {limit} bytes", str(path))
    return data


def _mode_for(path: Path) -> int:
    try:
        return stat.S_IMODE(path.stat().st_mode)
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


@contextlib.contextmanager
def replaced(path: str | Path, mode: str = "w", **open_args: Any) -> Iterator[IO[Any]]:
    """A file object whose content replaces ``path`` when the block ends without error.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "out.txt"
    >>> _ = target.write_text("old")
    >>> try:
    ...     with replaced(target) as fh:
    ...         _ = fh.write("new, half written")
    ...         raise OSError("disk full")
    ... except OSError:
    ...     pass
    >>> target.read_text(), sorted(p.name for p in target.parent.iterdir())
    ('old', ['out.txt'])
    >>> with replaced(target) as fh:
    ...     _ = fh.write("new")
    >>> target.read_text()
    'new'
    """
    target = Path(path)
    permissions = _mode_for(target)
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, mode, **open_args) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, permissions)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def replace_file(path: str | Path, write: Callable[[IO[Any]], object], binary: bool = False,
                 ) -> None:
    """Replace ``path`` atomically with what ``write`` writes to the file object it gets.

    Examples
    --------
    >>> import json, pathlib, tempfile
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "result.json"
    >>> replace_file(target, lambda fh: json.dump({"t_end": 10.0}, fh))
    >>> target.read_text()
    '{"t_end": 10.0}'
    >>> replace_file(target, lambda fh: fh.write(b"\\x00\\x01"), binary=True)
    >>> target.read_bytes()
    b'\\x00\\x01'
    """
    if binary:
        with replaced(path, "wb") as fh:
            write(fh)
    else:
        with replaced(path, "w", encoding="utf-8", newline="") as fh:
            write(fh)


def replace_text(path: str | Path, text: str) -> None:
    """Replace ``path`` atomically with ``text`` (UTF-8).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "note.txt"
    >>> replace_text(target, "h = 10 m\\n")
    >>> target.read_text(encoding="utf-8")
    'h = 10 m\\n'
    """
    replace_file(path, lambda fh: fh.write(text))
