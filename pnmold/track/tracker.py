"""Frames of a bending actuator to measurements: :func:`track`.

The first frame is the rest: the clicks and its look teach :mod:`.appearance` the body; every frame
is masked and traced (:mod:`.centreline`) from the base; the side the body curls to (the frame that
turns most) names the bottom edge; the rest trace fixes pnmold's axes (:mod:`.measure`); the scale
comes from :mod:`.scale`; each frame is read, and accepted when nothing refuses it and its confidence
reaches :data:`MIN_CONFIDENCE`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from pnmold.errors import UsageError
from pnmold.track.appearance import Appearance, check_point, learn_appearance
from pnmold.track.centreline import Trace, trace_body
from pnmold.track.endmatch import EndPatch, end_patch, match_end_turn
from pnmold.track.measure import (
    END_CUT_WIDTHS,
    Axes,
    end_tangent_turn,
    read_frame,
    reads_by_look,
    rest_axes,
    rest_turn,
)
from pnmold.track.media import Footage, Frame, read_frames
from pnmold.track.pressures import PressureLog
from pnmold.track.scale import Scale, grid_scale

log = logging.getLogger(__name__)

#: a frame is accepted from this confidence up
MIN_CONFIDENCE = 0.5
#: the first frame's body must stand out this well from its surroundings (0..1)
MIN_CONTRAST = 0.5
#: a clamp that moved more than this (px) since the first frame: the camera moved
CAMERA_SHIFT_PX = 2.0
#: ... when the clamp's picture correlates this well with the first frame's (else it has too little detail
#: to say, or is hidden)
CAMERA_RESPONSE = 0.3


@dataclass(frozen=True)
class TrackOptions:
    """What the command line gives: the clicks (px on the first frame), the pressures (one per frame,
    or a log), one way to the scale (mm per px, a grid's square in mm, or the free length in mm), the
    design's clamp offset (x of the clamp's end in pnmold's frame), video timing, and who it is."""

    base_px: tuple[float, float]
    tip_px: tuple[float, float]
    pressures_kpa: tuple[float, ...] | None = None
    pressure_log: PressureLog | None = None
    mm_per_px: float | None = None
    grid_mm: float | None = None
    free_length_mm: float | None = None
    free_length_source: str = "given"
    clamp_end_mm: float = 0.0
    every: int = 1
    fps: float | None = None
    offset_s: float = 0.0


@dataclass(frozen=True, eq=False)
class TrackedFrame:
    """One frame's result: accepted or skipped (``reason``), its confidence (0..1), pressure and time,
    the bend angle (deg) and tip (mm, pnmold's frame) when measured, and its trace (px) for drawing."""

    index: int
    name: str
    time_s: float | None
    pressure_kpa: float | None
    supply_kpa: float | None
    accepted: bool
    confidence: float
    reason: str | None
    bend_angle_deg: float | None
    tip_x_mm: float | None
    tip_z_mm: float | None
    angle_from: str | None
    edge_minus_angle_deg: float | None
    trace: Trace | None = field(default=None, repr=False)
    tip_px: tuple[float, float] | None = None

    def to_json(self) -> dict:
        def num(v, nd=4):
            return None if v is None else round(float(v), nd)

        return {"index": self.index, "name": self.name, "time_s": num(self.time_s, 6),
                "pressure_kpa": num(self.pressure_kpa), "accepted": self.accepted,
                "confidence": num(self.confidence, 3), "reason": self.reason,
                "bend_angle_deg": num(self.bend_angle_deg, 3), "tip_x_mm": num(self.tip_x_mm, 3),
                "tip_z_mm": num(self.tip_z_mm, 3), "angle_from": self.angle_from,
                "edge_minus_angle_deg": num(self.edge_minus_angle_deg, 2)}


@dataclass(frozen=True, eq=False)
class Tracking:
    """Every frame's result, the scale, the length the angles are over and where the frames came from."""

    frames: tuple[TrackedFrame, ...]
    scale: Scale
    bending_length_mm: float
    clamp_end_mm: float
    curl: str
    footage: Footage
    base_px: tuple[float, float]
    tip_px: tuple[float, float]
    contrast: float
    axes: Axes = field(repr=False)

    @property
    def accepted(self) -> list[TrackedFrame]:
        return [f for f in self.frames if f.accepted]

    def to_json(self) -> dict:
        return {"schema": "pnmold.track/1", "frames_total": len(self.frames), "frames_accepted": len(self.accepted),
                "footage": self.footage.words(), "base_px": list(self.base_px), "tip_px": list(self.tip_px),
                "scale": {"mm_per_px": round(self.scale.mm_per_px, 6), "source": self.scale.source,
                          "words": self.scale.words},
                "bending_length_mm": round(self.bending_length_mm, 3), "clamp_end_mm": self.clamp_end_mm,
                "curl": self.curl, "contrast": round(self.contrast, 3),
                "frames": [f.to_json() for f in self.frames]}


def track(paths: Sequence[str], options: TrackOptions,
          progress: Callable[[int, int], None] | None = None) -> Tracking:
    """Track the frames of ``paths`` (images in order, or one video) with ``options``."""
    frames, footage = read_frames(list(paths), options.every, options.fps)
    return track_frames(frames, footage, options, progress)


def track_frames(frames: list[Frame], footage: Footage, options: TrackOptions,
                 progress: Callable[[int, int], None] | None = None) -> Tracking:
    """Track frames already read (:func:`pnmold.track.media.read_frames`) with ``options``."""
    pressures = _pressures(frames, options)
    base = check_point("base", options.base_px, footage.size_px)
    tip = check_point("tip", options.tip_px, footage.size_px)
    model = learn_appearance(frames[0].image, base, tip)
    if model.contrast < MIN_CONTRAST:
        raise UsageError(f"FRAMES: in the first frame the body does not stand out from its surroundings (contrast "
                         f"{model.contrast:.2f} < {MIN_CONTRAST}); light it evenly against a plain background "
                         "of another colour or brightness (docs/track.md)")
    start = base + 0.5 * (model.half_width_a_px - model.half_width_b_px) * model.normal
    traces, masks0, first = [], model.mask(frames[0].image), _gray(frames[0].image)
    for i, frame in enumerate(frames):
        moved = None if i == 0 else _camera_moved(first, _gray(frame.image), model)
        mask = masks0 if i == 0 else model.mask(frame.image)
        trace = trace_body(mask, start, model.direction, model.width_px, 3.0 * model.length_px)
        traces.append(trace if moved is None else replace(trace, reason=moved))
        if progress:
            progress(i + 1, len(frames))
    rest = traces[0]
    if rest.reason or rest.at_border:
        why = rest.reason or "it reaches the border"
        raise UsageError(f"--base/--tip: the body cannot be traced in the first frame ({why}); click where it "
                         "leaves the clamp and the middle of its free end")
    side = _curl_side(traces)
    axes = rest_axes(rest, start, side)
    scale = _scale(frames[0], model, axes, options)
    patch = None
    if reads_by_look(rest, axes, model.width_px):
        patch = end_patch(_gray(frames[0].image), masks0, rest.end_px, rest.direction,
                          rest_turn(rest, axes, model.width_px), model.width_px)
    results = tuple(_result(frames[i], traces[i], rest, axes, model, scale, options, pressures[i], patch)
                    for i in range(len(frames)))
    curl = "clockwise" if side > 0 else "counter-clockwise"
    return Tracking(results, scale, axes.length_px * scale.mm_per_px, options.clamp_end_mm,
                    f"{curl} in the picture (seen as filmed)", footage, tuple(map(float, base)),
                    tuple(map(float, tip)), model.contrast, axes)


def _pressures(frames: list[Frame], options: TrackOptions) -> list[tuple[float | None, float | None]]:
    """(pressure, supply) per frame."""
    if options.pressures_kpa is not None:
        if len(options.pressures_kpa) != len(frames):
            raise UsageError(f"--pressures-kpa: {len(options.pressures_kpa)} pressure(s) for {len(frames)} frame(s); "
                             "give one pressure per frame tracked")
        return [(p, None) for p in options.pressures_kpa]
    if options.pressure_log is None:
        raise UsageError("--pressures-kpa or --pressure-log: give the pressure of each frame")
    if frames[0].time_s is None:
        raise UsageError("--pressure-log: the frames have no times; give --fps (photographs, or a video without "
                         "a frame rate)")
    return [options.pressure_log.at(f.time_s + options.offset_s) for f in frames]


def _curl_side(traces: list[Trace]) -> int:
    """+1 when the body curls toward the normal (clockwise in the picture), -1 the other way: the sign of
    the turn of the frame that turns most (+1 when none turns)."""
    turns = [t.end_turn_rad for t in traces if t.reason is None]
    if not turns:
        return 1
    most = max(turns, key=abs)
    return 1 if most >= 0 or abs(most) < math.radians(2) else -1


def _scale(first: Frame, model: Appearance, axes: Axes, options: TrackOptions) -> Scale:
    import cv2

    given = [n for n, v in (("--scale-mm-per-px", options.mm_per_px), ("--grid-mm", options.grid_mm))
             if v is not None]
    if len(given) > 1:
        raise UsageError(f"{given[0]} and {given[1]}: give one way to the scale")
    if options.mm_per_px is not None:
        if not options.mm_per_px > 0:
            raise UsageError(f"--scale-mm-per-px: {options.mm_per_px} is not a positive number")
        return Scale(options.mm_per_px, "mm-per-px", f"{options.mm_per_px:g} mm per px, given")
    if options.grid_mm is not None:
        near = (model.probability(first.image) > 0.3).astype(np.uint8)
        exclude = cv2.dilate(near, np.ones((9, 9), np.uint8)) > 0
        return grid_scale(first.image, exclude, options.grid_mm)[0]
    if options.free_length_mm is None:
        raise UsageError("--scale-mm-per-px, --grid-mm, --free-length-mm or --design: give one way to the scale")
    if not options.free_length_mm > 0:
        raise UsageError(f"--free-length-mm: {options.free_length_mm} is not a positive number")
    mm = options.free_length_mm / axes.length_px
    return Scale(mm, "free-length", f"free length {options.free_length_mm:g} mm ({options.free_length_source}) "
                 f"over {axes.length_px:.1f} px traced at rest")


def _camera_moved(first: np.ndarray, gray: np.ndarray, model: Appearance) -> str | None:
    """Why the frame cannot be measured in the first frame's axes, or None: the clamp (the picture just
    behind the base, as wide as the body) moved, or is no longer seen (phase correlation with the
    first frame)."""
    import cv2

    r = int(max(8, 1.2 * model.width_px))
    centre = model.base_px - 1.3 * r * model.direction
    x0, y0 = int(centre[0]) - r, int(centre[1]) - r
    h, w = gray.shape
    if x0 < 0 or y0 < 0 or x0 + 2 * r > w or y0 + 2 * r > h:
        return None  # the clamp is at the border: nothing to compare
    detail0, detail = (float(cv2.GaussianBlur(g, (0, 0), 2.0).std()) for g in (first, gray))
    if detail < 0.25 * detail0:
        return "camera covered: the picture lost its detail"
    a, b = first[y0:y0 + 2 * r, x0:x0 + 2 * r], gray[y0:y0 + 2 * r, x0:x0 + 2 * r]
    window = cv2.createHanningWindow((2 * r, 2 * r), cv2.CV_32F)
    (dx, dy), response = cv2.phaseCorrelate(a, b, window)
    if response >= CAMERA_RESPONSE and math.hypot(dx, dy) > CAMERA_SHIFT_PX:
        return f"camera moved: the clamp shifted by ({dx:.1f}, {dy:.1f}) px since the first frame"
    return None


def _gray(image: np.ndarray) -> np.ndarray:
    import cv2

    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY).astype(np.float32)


def _result(frame: Frame, trace: Trace, rest: Trace, axes: Axes, model: Appearance, scale: Scale,
            options: TrackOptions, pressure: tuple[float | None, float | None],
            patch: EndPatch | None) -> TrackedFrame:
    p, supply = pressure
    common = {"index": frame.index, "name": frame.name, "time_s": frame.time_s, "pressure_kpa": p,
              "supply_kpa": supply, "trace": trace}
    if trace.reason:
        return TrackedFrame(**common, accepted=False, confidence=0.0, reason=trace.reason, bend_angle_deg=None,
                            tip_x_mm=None, tip_z_mm=None, angle_from=None, edge_minus_angle_deg=None)
    match = None
    if patch is not None:  # the end is read by its look (reads_by_look)
        span = max(1.5 * model.width_px, 0.25 * axes.length_px)
        edge = end_tangent_turn(trace, axes.side, span, trace.direction, END_CUT_WIDTHS * model.width_px)[0]
        guess = float(np.median([trace.end_turn_rad, trace.turn_rad[-1], edge]))
        match = (patch.rest_turn_rad, 1.0) if frame.index == 0 else \
            match_end_turn(_gray(frame.image), patch, trace.end_px, trace.direction, guess)
    r = read_frame(trace, rest, axes, model.width_px, match)
    reason = r.reason
    if reason is None and frame.index > 0 and np.hypot(*(trace.end_px - model.base_px)) < model.width_px:
        reason = "the free end is at the clamp: it cannot be told from it"
    if reason is None and p is None:
        reason = "no pressure: the frame's time lies outside the pressure log"
    accepted = reason is None and r.confidence >= MIN_CONFIDENCE
    mm = scale.mm_per_px
    corner = trace.end_a_px if axes.side > 0 else trace.end_b_px
    return TrackedFrame(**common, accepted=accepted, confidence=r.confidence, reason=reason,
                        bend_angle_deg=r.bend_angle_deg, tip_x_mm=options.clamp_end_mm + r.tip_x_px * mm,
                        tip_z_mm=r.tip_z_px * mm, angle_from=r.angle_from, edge_minus_angle_deg=r.edge_minus_angle_deg,
                        tip_px=(float(corner[0]), float(corner[1])))
