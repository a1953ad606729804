"""How a recording was measured: the frame of its tip, the length its bend angle was computed
over, and the rig of a pressure-volume test (recording metadata, docs/recording-format.md).

A lab's camera does not sit at pnmold's clamp, a lab computes a bend angle from a curvature
over its own length, and a piston also compresses the air between it and the actuator. These
are facts of the measurement, not physics the model lacks: the diagnosis maps its predictions
through them (:mod:`pnmold.diagnose.registration`) and calibrates what is unknown (a camera's
offset and rotation) with the modulus, never blaming them on an effect.

Defaults are pnmold's own frame and the supplement's P-V test (water from a syringe pump).
Read by the one metadata parser, :mod:`pnmold.recording.metadata`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from pnmold.recording.metadata import metadata_choice, metadata_number

#: where a recorded tip is measured from
TIP_ORIGINS = ("clamp", "rest", "camera")
#: how a P-V test drives the actuator: a volume (piston, syringe) or a pressure (regulator)
RIGS = ("volume", "pressure")
#: what fills the rig and the actuator in a P-V test
MEDIA = ("water", "air")

#: metadata key -> (recording kinds that read it, what it says), for the docs and the templates
KEYS = {
    "tip_origin": (("bending",), "where the recorded tip is measured from: clamp (pnmold's frame: x along the "
                   "actuator from the clamped end, z up from the bottom face; the default) | rest (the tip's own "
                   "rest position at 0 kPa, gravity included: recorded = tip - tip at rest) | camera (a frame "
                   "of its own: its offset and rotation are calibrated with the modulus)"),
    "bending_length_mm": (("bending",), "the length the bend angle was computed over (angle = curvature x "
                          "length, constant curvature assumed; default the actuator's free length, from the "
                          "clamp to the tip)"),
    "rig": (("pv",), "volume (a piston or syringe pump sets the volume; the default: a recording of one loading "
            "ramp, without cycles, is read by its volume, the model's pressure at each recorded volume compared with "
            "the recorded pressure) | pressure (a regulator sets the pressure and volume_ml is the gas metered in, in "
            "standard mL at 0 degC and 101.325 kPa)"),
    "medium": (("pv",), "water (the supplement's hydraulic test; the default) | air"),
    "air_column_ml": (("pv",), "known volume of air at atmospheric pressure between the piston (or meter) and "
                      "the actuator, e.g. the tubing and the cylinder's dead space (default 0; an unknown one is "
                      "what the dead_volume effect finds)"),
    "pressure_accuracy_kpa": (("pv",), "the rig's stated pressure accuracy (e.g. from the transducer's datasheet; "
                              "default 0): a named dead volume is checked against the air the rows allow within it"),
    "volume_accuracy_ml": (("pv",), "the rig's stated volume accuracy (e.g. the piston's position accuracy times "
                           "its area; default 0), used alike"),
}


@dataclass(frozen=True)
class Measurement:
    """What a recording's metadata says of how it was measured (see :data:`KEYS`)."""

    tip_origin: str = "clamp"
    bending_length_mm: float | None = None
    rig: str = "volume"
    medium: str = "water"
    air_column_ml: float = 0.0
    pressure_accuracy_kpa: float = 0.0
    volume_accuracy_ml: float = 0.0

    @property
    def compresses_air(self) -> bool:
        """The recorded volume includes the compression of gas (air in the rig and the cavity)."""
        return self.medium == "air"


def measurement_of(metadata: Mapping[str, str], path: str) -> Measurement:
    """The :class:`Measurement` of a recording's metadata; RecordingError names the key."""
    meta = metadata
    return Measurement(metadata_choice(meta, "tip_origin", TIP_ORIGINS, "clamp", path),
                       metadata_number(meta, "bending_length_mm", path),
                       metadata_choice(meta, "rig", RIGS, "volume", path),
                       metadata_choice(meta, "medium", MEDIA, "water", path),
                       metadata_number(meta, "air_column_ml", path, closed=True) or 0.0,
                       metadata_number(meta, "pressure_accuracy_kpa", path, closed=True) or 0.0,
                       metadata_number(meta, "volume_accuracy_ml", path, closed=True) or 0.0)
