"""Import and export of other model formats (SpaceEx XML + ``.cfg``).

The importers build ordinary :class:`hybridlab.Model` objects; every expression goes
through hybridlab's whitelist parser, never ``eval``.
"""

from typing import TYPE_CHECKING

from hybridlab._lazy import lazy_exports

if TYPE_CHECKING:  # the public names, loaded on first use (hybridlab._lazy)
    from hybridlab.io._sxheader import problem_header
    from hybridlab.io._sxnetwork import (
        SpaceExComponents,
        loads_spaceex_components,
        spaceex_components,
    )
    from hybridlab.io.spaceex import (
        ConstraintSet,
        SpaceExError,
        SpaceExOptions,
        SpaceExProblem,
        load_spaceex,
        loads_spaceex,
    )

__getattr__, __dir__ = lazy_exports(__name__, __file__)

__all__ = [
    "ConstraintSet",
    "SpaceExComponents",
    "SpaceExError",
    "SpaceExOptions",
    "SpaceExProblem",
    "load_spaceex",
    "loads_spaceex",
    "loads_spaceex_components",
    "problem_header",
    "spaceex_components",
]
