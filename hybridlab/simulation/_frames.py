"""Results as pandas DataFrames (the ``pandas`` extra), imported only when one is made."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np


def pandas() -> Any:
    """The pandas module, or an ImportError naming the extra that installs it.

    Examples
    --------
    >>> pandas().DataFrame({"t": [0.0]}).shape
    (1, 1)
    """
    try:
        import pandas as pd
    except ImportError as exc:  # optional dependency
        raise ImportError("DataFrames need pandas: pip install 'hybridlab[pandas]'") from exc
    return pd


def frame(columns: dict[str, Any], state_names: Sequence[str],
          *states: tuple[str, np.ndarray]) -> Any:
    """A DataFrame of ``columns``, then for each ``(prefix, values)`` of ``states`` one column
    per state, ``prefix + name``, from the rows of ``values`` (shape ``(n, k)``). A state
    named like one of ``columns`` (a state ``j``) gets a column of its own with the same
    name, as in the CSV export.

    Examples
    --------
    >>> frame({"t": [0.0, 1.0]}, ("x",), ("pre_", np.array([[2.0, 3.0]])),
    ...       ("post_", np.array([[0.0, 1.0]])))
         t  pre_x  post_x
    0  0.0    2.0     0.0
    1  1.0    3.0     1.0
    """
    df = pandas().DataFrame(columns)
    for prefix, values in states:
        for name, row in zip(state_names, values, strict=True):
            df.insert(len(df.columns), prefix + name, row, allow_duplicates=True)
    return df
