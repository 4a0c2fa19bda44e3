"""A small progress bar on stderr (no dependency)."""

from __future__ import annotations

import os
import sys
import time
from typing import TextIO

__all__ = ["ProgressBar", "progress_wanted"]


def progress_wanted(progress: bool | None, stream: TextIO | None = None) -> bool:
    """Resolve ``progress=None`` (auto): on for a terminal, off in CI and when redirected.

    Examples
    --------
    >>> import io
    >>> progress_wanted(None, io.StringIO()), progress_wanted(True, io.StringIO())
    (False, True)
    """
    if progress is not None:
        return bool(progress)
    stream = stream if stream is not None else sys.stderr
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty()) and not os.environ.get("CI")


class ProgressBar:
    """``[#######.........]  45/100 runs  12 s  eta 15 s`` redrawn in place.

    Redraws at most ten times a second; :meth:`close` ends the line. With
    ``enabled=False`` every method does nothing.

    Examples
    --------
    >>> import io
    >>> out = io.StringIO()
    >>> bar = ProgressBar(4, enabled=True, stream=out, width=8)
    >>> bar.update(4); bar.close()
    >>> out.getvalue().strip().splitlines()[-1].startswith("[########]  4/4 runs")
    True
    """

    def __init__(self, total: int, *, enabled: bool, stream: TextIO | None = None,
                 width: int = 30) -> None:
        self.total = total
        self.enabled = enabled
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.done = 0
        self._start = time.perf_counter()
        self._last = -1.0

    def update(self, n: int = 1) -> None:
        self.done += n
        if not self.enabled:
            return
        now = time.perf_counter()
        if now - self._last < 0.1 and self.done < self.total:
            return
        self._last = now
        elapsed = now - self._start
        filled = self.width * self.done // max(self.total, 1)
        bar = "#" * filled + "." * (self.width - filled)
        digits = len(str(self.total))
        text = f"\r[{bar}] {self.done:>{digits + 1}}/{self.total} runs  {elapsed:.0f} s"
        if 0 < self.done < self.total:
            text += f"  eta {elapsed * (self.total - self.done) / self.done:.0f} s"
        self.stream.write(text + "   ")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()
