"""Import and export of other model formats (SpaceEx XML + ``.cfg``).

The importers build ordinary :class:`hybridlab.Model` objects; every expression goes
through hybridlab's whitelist parser, never ``eval``.
"""

from hybridlab.io.spaceex import (
    ConstraintSet,
    SpaceExError,
    SpaceExOptions,
    SpaceExProblem,
    load_spaceex,
    loads_spaceex,
)

__all__ = [
    "ConstraintSet",
    "SpaceExError",
    "SpaceExOptions",
    "SpaceExProblem",
    "load_spaceex",
    "loads_spaceex",
]
