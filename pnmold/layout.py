"""How each mold is used: printed, poured into and pulled off its cast part.

Directions are unit vectors in the actuator frame (CONTRACTS.md §2). Shared by the CAD
export (print-oriented copies) and the checks, so the two cannot disagree.
"""

from __future__ import annotations

from dataclasses import dataclass

MOLDS = ("mold_interior", "mold_exterior", "mold_bottom")
CAST_PARTS = ("actuator", "top_layer", "bottom_layer", "passive_layer", "paper")


@dataclass(frozen=True)
class MoldUse:
    name: str
    cast_part: str  # the cast part it shapes
    print_up: tuple[float, float, float]  # actuator-frame direction that points up on the bed
    pull: tuple[float, float, float]  # direction the mold moves to leave the cast part
    pour_up: tuple[float, float, float] | None  # up while pouring, for a vessel; None otherwise


USES = {
    # the plate prints on the bed, cores up; it is pulled down out of the top layer
    "mold_interior": MoldUse("mold_interior", "top_layer", (0, 0, 1), (0, 0, -1), None),
    # prints and is poured ceiling down (turned over); it lifts off the top layer along +z
    "mold_exterior": MoldUse("mold_exterior", "top_layer", (0, 0, -1), (0, 0, 1), (0, 0, -1)),
    # the tray prints and is poured floor down; the cast layer lifts out along +z
    "mold_bottom": MoldUse("mold_bottom", "bottom_layer", (0, 0, 1), (0, 0, -1), (0, 0, 1)),
}
