"""The rest rows, checked first: where a bending recording puts the tip at 0 kPa, against every rest
the rig as declared allows.

At rest the actuator holds only its weight: its tip sags along the declared orientation by an amount
set by the weight over the stiffness (gravity x density / modulus). Over everything the nuisances and
the gravity effect allow (gravity 0-2 g, the modulus down to the window's lowest, the density up to its
highest) the model's rest tips trace one curve. A recorded rest tip far from that curve is not physics
the model lacks; it is a question of the declaration, named with the metadata key that settles it:

- **orientation**: the tip sags the other way (the actuator hung chambers down, say, not up); held
  horizontal, a tip off along +z may also be the body rolling under its weight further than the model's
  roll (from the FE's roll probe; without the probe the model has none), which the words say;
- **free length / frame origin**: the tip is nearer to (or farther from) the clamp than any rest of the
  actuator (the lab measured from the clamp's edge, or the free length is not the design's);
- **frame**: at the right distance but turned (the recording's axes are not x along the actuator and z
  up from its bottom face).

Where the recording does not state ``tip_origin`` (the frame is the lab's to say and it did not), a
recording whose rest fails for the frame or the origin is judged from its own rest rows, as
``tip_origin: rest`` would be: its offset does not pass for physics. A camera frame (``tip_origin:
camera``) is registered by the calibration instead; after it, the calibrated frame must still put the
model's rest where the rest rows are (:func:`frame_notes`): a frame moved off them to fit the rest of the
curve absorbs a misfit of the model, which is said.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from pnmold.recording import Recording

from .calibrate import DENSITY_WINDOW, WINDOW
from .fitting import Forward

#: rows at or below this gauge pressure are at rest (assumed: a transducer's zero reading)
REST_KPA = 0.5
#: how far a recorded rest tip may lie from the model's rests (assumed: a lab reads a rest tip to a couple
#: of millimetres, or 2 % of the actuator's free length), or 5 times the rest rows' own scatter
REST_TOLERANCE_MM, REST_TOLERANCE_SHARE, REST_SCATTER = 2.0, 0.02, 5.0
#: gravity values (g) the rests are traced over, at the softest modulus and the heaviest density allowed
GRAVITY_GRID = np.linspace(0.0, 2.0, 41)
#: a calibrated camera frame may leave the rest rows' residual this many noise levels from zero
FRAME_REST_Z = 5.0


@dataclass(frozen=True)
class RestCheck:
    """One bending recording's rest rows against the model's rests (``question`` None: they agree)."""

    recording: str
    rows: int
    observable: str  # tip (x, z in mm) or bend_angle_deg
    recorded: tuple[float, ...]
    model: tuple[float, ...]  # the nearest rest the declaration allows
    distance: float  # mm, or deg for the angle
    tolerance: float
    question: str | None  # orientation, free_length, frame, bending_length
    key: str | None  # the metadata key that settles it
    registered: bool  # judged from its own rest rows (tip_origin: rest)
    words: str

    def as_json(self) -> dict[str, Any]:
        unit = "deg" if self.observable == "bend_angle_deg" else "mm"
        return {"recording": self.recording, "rows": self.rows, "observable": self.observable,
                f"recorded_{unit}": [round(v, 4) for v in self.recorded],
                f"model_{unit}": [round(v, 4) for v in self.model], f"distance_{unit}": round(self.distance, 4),
                f"tolerance_{unit}": round(self.tolerance, 4), "question": self.question, "key": self.key,
                "registered_at_rest": self.registered, "words": self.words}


def rest_rows(rec: Recording) -> np.ndarray:
    """Indices of the rows at rest (gauge pressure at most :data:`REST_KPA`)."""
    return np.flatnonzero(np.asarray(rec.columns["pressure_kpa"], float) <= REST_KPA)


#: the same for a recording of the bend angle alone, in degrees (assumed: an angle from a camera's curvature)
REST_TOLERANCE_DEG = 3.0


def _has_tip(rec: Recording) -> bool:
    return {"tip_x_mm", "tip_z_mm"} <= set(rec.columns)


def _checked(rec: Recording) -> bool:
    return (rec.kind == "bending" and (_has_tip(rec) or "bend_angle_deg" in rec.columns)
            and rec.measurement.tip_origin != "camera" and rest_rows(rec).size > 0)


def check_rest(recordings: Sequence[Recording], forward: Forward, free_length_mm: float
               ) -> tuple[list[RestCheck], list[Recording]]:
    """Every bending recording's rest rows against the model's rests (see the module docstring); the checks
    and the recordings to judge (those registered at rest replaced)."""
    if not any(_checked(r) for r in recordings):
        return [], list(recordings)
    softest = {"modulus_scale": WINDOW[0], "density_scale": DENSITY_WINDOW[1]}
    family = [forward({"gravity": float(g)}, softest) for g in GRAVITY_GRID]
    checks, out = [], []
    for i, rec in enumerate(recordings):
        if not _checked(rec):
            out.append(rec)
            continue
        rows = rest_rows(rec)
        if not _has_tip(rec):
            checks.append(_judge_angle(rec, rows, np.array([float(np.nanmean(np.asarray(
                f[i]["bend_angle_deg"], float)[rows])) for f in family])))
            out.append(rec)
            continue
        x, z = (np.asarray(rec.columns[k], float)[rows] for k in ("tip_x_mm", "tip_z_mm"))
        path = np.array([[float(np.nanmean(np.asarray(f[i][k], float)[rows])) for k in ("tip_x_mm", "tip_z_mm")]
                         for f in family])
        check = _judge(rec, (float(x.mean()), float(z.mean())), path, rows.size,
                       _tolerance(free_length_mm, x, z), free_length_mm)
        checks.append(check)
        out.append(registered(rec, check.recorded) if check.registered else rec)
    return checks, out


def _tolerance(free_length_mm: float, x: np.ndarray, z: np.ndarray) -> float:
    scatter = float(np.hypot(x.std(ddof=1), z.std(ddof=1))) if x.size > 1 else 0.0
    return max(REST_TOLERANCE_MM, REST_TOLERANCE_SHARE * free_length_mm, REST_SCATTER * scatter)


def _judge(rec: Recording, recorded: tuple[float, float], path: np.ndarray, n: int, tol: float,
           free_length_mm: float) -> RestCheck:
    """The recorded rest against the model's rests ``path`` (rows: gravity 0 to 2 g)."""
    ok = np.all(np.isfinite(path), axis=1)
    path = path[ok]
    distances = np.hypot(path[:, 0] - recorded[0], path[:, 1] - recorded[1])
    k = int(np.argmin(distances))
    nearest, d = (float(path[k, 0]), float(path[k, 1])), float(distances[k])
    base = dict(recording=rec.path, rows=n, observable="tip", recorded=recorded, model=nearest, distance=d,
                tolerance=tol)
    if d <= tol:
        return RestCheck(**base, question=None, key=None, registered=False, words="")
    rows = f"{n} row{'s' if n != 1 else ''}"
    at = (f"The rest rows of {rec.path} ({rows} at {REST_KPA:g} kPa or less) put the tip at ({recorded[0]:.1f}, "
          f"{recorded[1]:.1f}) mm, {d:.1f} mm from every rest the declared rig allows (nearest "
          f"({nearest[0]:.1f}, {nearest[1]:.1f}) mm; tolerance {tol:.1f} mm)")
    sag = float(path[-1, 1] - path[0, 1])  # toward where the weight pulls the tip
    roll_words = (" Unless the rig is horizontal and the body rolls further: held on its side, a soft or tall body "
                  "turns about its length under its own weight, its chambers toward the ground, which brings part of "
                  "the weight into the bending plane along +z (the FE of the whole body carries the roll: `pnmold "
                  "simulate DESIGN --model fe --orientation horizontal`; the reduced model carries it through its "
                  "roll probe, where that served).")
    top = float(np.max(path[:, 1]))
    side = rec.measurement.tip_origin == "clamp" and rec.orientation == "horizontal"
    if side and sag > tol and recorded[1] > top + tol:
        words = (f"{at}: the tip rests further toward +z than the body held on its side rolls and sags under any "
                 f"weight the declaration allows (at most {top:.1f} mm). A question of the declaration, not physics: "
                 f"the metadata key `orientation` settles it (chambers_down: the weight along +z; horizontal: out "
                 f"of the plane).{roll_words}")
        return RestCheck(**base, question="orientation", key="orientation", registered=False, words=words)
    if rec.measurement.tip_origin == "clamp" and abs(sag) > tol and (recorded[1] - path[0, 1]) * sag < -tol * abs(sag):
        words = (f"{at}: the tip sags {'up' if sag < 0 else 'down'}, against the weight of the declared "
                 f"{rec.orientation}. A question of the declaration, not physics: the metadata key `orientation` "
                 f"settles it (chambers_up: the weight along -z; chambers_down: along +z).")
        return RestCheck(**base, question="orientation", key="orientation", registered=False, words=words)
    if rec.measurement.tip_origin == "clamp" and abs(sag) <= tol and abs(recorded[1] - path[0, 1]) > tol:
        words = (f"{at}: the tip sags {'down' if recorded[1] < path[0, 1] else 'up'}, though the declared "
                 f"{rec.orientation} puts the weight out of the bending plane. A question of the declaration, not "
                 f"physics: the metadata key `orientation` settles it (chambers_up: the weight along -z; "
                 f"chambers_down: along +z; horizontal: out of the plane).")
        if rec.orientation == "horizontal" and recorded[1] > path[0, 1]:
            words += roll_words
        return RestCheck(**base, question="orientation", key="orientation", registered=False, words=words)
    r_rec, r_model = math.hypot(*recorded), math.hypot(*nearest)
    if rec.measurement.tip_origin == "rest":
        question, key = "frame", "tip_origin"
        words = (f"{at}: with `tip_origin: rest` the tip at rest is (0, 0). A question of the frame: the metadata "
                 f"key `tip_origin` settles it (clamp: from the clamp's edge; camera: a frame of its own).")
    elif abs(r_rec - r_model) > tol:
        question, key = "free_length", "tip_origin"
        words = (f"{at}: the tip is {abs(r_rec - r_model):.1f} mm {'nearer to' if r_rec < r_model else 'farther from'} "
                 f"the clamp than any rest of the actuator (free length {free_length_mm:.1f} mm). A question of the "
                 f"frame's origin or the free length, not physics: the metadata key `tip_origin` settles the first "
                 f"(rest: the tip less its rest position; camera: a frame of its own, calibrated), the design's "
                 f"clamp.length_mm and chamber sizes the second.")
    else:
        question, key = "frame", "tip_origin"
        turn = math.degrees(math.atan2(recorded[1], recorded[0]) - math.atan2(nearest[1], nearest[0]))
        words = (f"{at}: at the actuator's distance from the clamp but turned {turn:.1f} deg. A question of the "
                 f"frame, not physics: the recording's axes are not x along the actuator and z up from its bottom "
                 f"face; the metadata key `tip_origin` settles it (camera: the frame's offset and turn calibrated).")
    register = "tip_origin" not in rec.metadata
    if register:
        words += (" The recording does not state tip_origin: it is judged from its own rest rows (as tip_origin: "
                  "rest), so the offset does not pass for physics.")
    return RestCheck(**base, question=question, key=key, registered=register, words=words)


def _judge_angle(rec: Recording, rows: np.ndarray, family: np.ndarray) -> RestCheck:
    """A recording of the bend angle alone: its rest angle against the model's rest angles ``family``."""
    angle = np.asarray(rec.columns["bend_angle_deg"], float)[rows]
    tol = max(REST_TOLERANCE_DEG, REST_SCATTER * float(angle.std(ddof=1)) if angle.size > 1 else 0.0)
    family = family[np.isfinite(family)]
    k = int(np.argmin(np.abs(family - angle.mean())))
    d = float(abs(family[k] - angle.mean()))
    base = dict(recording=rec.path, rows=int(rows.size), observable="bend_angle_deg", recorded=(float(angle.mean()),),
                model=(float(family[k]),), distance=d, tolerance=tol)
    if d <= tol:
        return RestCheck(**base, question=None, key=None, registered=False, words="")
    sag = float(family[-1] - family[0])
    at = (f"The rest rows of {rec.path} put the bend angle at {angle.mean():.1f} deg, {d:.1f} deg from every rest "
          f"the declared rig allows (nearest {family[k]:.1f} deg; tolerance {tol:.1f} deg)")
    if (angle.mean() - family[0]) * sag < 0 or abs(sag) <= tol:
        return RestCheck(**base, question="orientation", key="orientation", registered=False, words=(
            f"{at}: the actuator curls at rest where its declared {rec.orientation} cannot make it. A question of the "
            f"declaration, not physics: the metadata key `orientation` settles it."))
    return RestCheck(**base, question="bending_length", key="bending_length_mm", registered=False, words=(
        f"{at}. A question of how the angle was measured, not physics: the metadata key `bending_length_mm` "
        f"settles it (the length the angle was computed over, when it is not the actuator's free length)."))


def registered(rec: Recording, rest_mm: tuple[float, float]) -> Recording:
    """``rec`` read from its rest rows: the tip less the recorded rest, as ``tip_origin: rest``."""
    columns = {**rec.columns, "tip_x_mm": np.asarray(rec.columns["tip_x_mm"], float) - rest_mm[0],
               "tip_z_mm": np.asarray(rec.columns["tip_z_mm"], float) - rest_mm[1]}
    return replace(rec, columns=columns, measurement=replace(rec.measurement, tip_origin="rest"),
                   metadata={**rec.metadata, "tip_origin": "rest"})


def frame_notes(recordings: Sequence[Recording], data, final) -> list[str]:
    """Words on every camera-frame recording whose calibrated frame leaves the model's rest away from its
    rest rows by more than :data:`FRAME_REST_Z` noise levels (``data``: the judged data set, ``final``: the
    final candidate, its frame calibrated)."""
    if "frame_rotation_deg" not in final.fit.values:
        return []
    out = []
    for i, rec in enumerate(recordings):
        if rec.kind != "bending" or rec.measurement.tip_origin != "camera":
            continue
        rest = set(rest_rows(rec).tolist())
        worst = 0.0
        for s in data.series:
            if s.recording != i:
                continue
            at = np.array([r in rest for r in s.rows])
            if at.any():
                pred = np.asarray(final.fit.predictions[i][s.observable], float)[s.rows[at]]
                worst = max(worst, float(np.max(np.abs((s.y[at] - pred) / s.sigma[at]))))
        if worst > FRAME_REST_Z:
            v = final.fit.values
            out.append(f"The camera frame of {rec.path} was calibrated to an offset of ({v['frame_dx_mm']:.3g}, "
                       f"{v['frame_dz_mm']:.3g}) mm and a turn of {v['frame_rotation_deg']:.3g} deg, which leaves the "
                       f"model's rest {worst:.0f} noise levels from the recorded rest: the frame absorbs a misfit of "
                       f"the model, more than a registration may. Check the recording's axes, or measure the tip "
                       f"from the clamp (tip_origin: clamp) or from its rest (tip_origin: rest).")
    return out
