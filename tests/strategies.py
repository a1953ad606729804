"""Hypothesis strategies over the design space (shared by tests and benchmarks)."""

from __future__ import annotations

from hypothesis import strategies as st

from pnmold.design import load_design

_FLOATS = {
    # ranges reach a little past the rules' limits, so draws land on both sides of them
    "chambers.length_mm": (1.0, 12.0),
    "chambers.width_mm": (4.0, 28.0),
    "chambers.height_mm": (2.0, 18.0),
    "chambers.inside_wall_mm": (0.7, 3.0),
    "chambers.outer_wall_mm": (0.7, 4.0),
    "chambers.end_wall_mm": (2.0, 8.0),
    "chambers.tip_wall_mm": (0.7, 4.0),
    "clamp.length_mm": (0.5, 40.0),
    "chambers.gap_mm": (0.7, 4.0),
    "channel.height_mm": (0.4, 3.0),
    "channel.width_mm": (0.8, 4.0),
    "top_layer.floor_mm": (1.2, 5.0),
    "bottom_layer.thickness_mm": (1.2, 5.0),
    "paper.inset_mm": (1.6, 5.0),
    "paper.depth_mm": (0.3, 3.0),
    "inlet.diameter_mm": (1.7, 2.6),
    "inlet.axis_offset_mm": (-0.6, 0.6),
    "mold.wall_mm": (0.7, 6.0),
    "mold.clearance_mm": (0.05, 0.9),
    "mold.plate_mm": (0.7, 6.0),
    "mold.ledge_mm": (0.7, 6.0),
}


@st.composite
def design_overrides(draw) -> list[str]:
    """A list of ``--set`` overrides: kind, count and every size drawn at random."""
    sets = [f"design.kind={draw(st.sampled_from(['fpn', 'spn']))}",
            f"chambers.count={draw(st.integers(1, 20))}"]
    for key, (lo, hi) in _FLOATS.items():
        if draw(st.booleans()):
            value = draw(st.floats(lo, hi, allow_nan=False, allow_infinity=False))
            sets.append(f"{key}={round(value, 3)}")
    return sets


def load_drawn(overrides: list[str]):
    return load_design("fpn", overrides)
