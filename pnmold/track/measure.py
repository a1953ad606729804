"""A traced frame measured in pnmold's frame: the bend angle, the tip, and how far to trust them.

The rest frame fixes the axes: x along the body's bottom edge at rest (the side it curls toward,
the strain-limiting layer of a PneuNet seen from the side), from the base; z across it, positive
away from the side it curls to. The tip is the free end's corner on that edge, as pnmold's tip is
the free end's point on the bottom face. The bend angle is the turn of the free end from rest,
unwrapped past 180 degrees, positive as it curls: the direction of the bottom edge at its end
(a parabola through its last part, so a constant curvature is not read short) and the end face's
normal are two readings of it; their mean is reported, their difference lowers the confidence.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pnmold.track.centreline import Trace

#: a rest whose bottom edge bows less than this (px) over its first half is read as straight
REST_SAG_PX = 1.0
#: the bottom edge's length over its length at rest outside which a trace is refused
EDGE_RATIO_LIMITS = (0.8, 1.4)
#: at most this share of cross-sections may have merged with something of the body's colour
MERGED_SHARE = 0.25
#: the bottom edge near the end: fully trusted while it strays less than this (deg RMS) from a constant
#: curvature, not at all past 3 times it
SMOOTH_DEG = 2.0
#: the bottom edge's last stretch (in body widths at rest) left out of its direction's fit
END_CUT_WIDTHS = 0.6
#: the end's look matches a frame when the correlation reaches this
MATCH_SCORE = 0.25
#: the end face's readings (outline points picked with different cones) must agree within this (deg)
FACE_SPREAD_DEG = 2.0
#: the bottom edge's direction at the end may differ from the end face's by this (deg) plus this share of
#: the angle: the edge runs on past the face's turn as the end wall bulges, more the more it bends
EDGE_FACE_DEG = 4.0
EDGE_FACE_SHARE = 0.06
#: read by the end's look, the bottom edge's length over its length at rest may be within these
LOOK_RATIO_LIMITS = (0.7, 1.6)


@dataclass(frozen=True, eq=False)
class Axes:
    """pnmold's frame in the picture: origin (the base on the bottom edge), x and z as unit vectors in
    pixels, the curl side (+1: toward the trace's normal), the bottom edge's length at rest (px) and
    the body's thickness at rest (px); the length is along the edge, the free length when it is the
    strain-limiting layer."""

    origin_px: np.ndarray
    x_hat: np.ndarray
    z_hat: np.ndarray
    side: int
    length_px: float
    thickness_px: float

    def to_frame(self, point_px: np.ndarray) -> tuple[float, float]:
        v = np.asarray(point_px, float) - self.origin_px
        return float(v @ self.x_hat), float(v @ self.z_hat)


@dataclass(frozen=True)
class Reading:
    """One frame's measurement in pixels and degrees (scaled to mm by the caller)."""

    bend_angle_deg: float
    tip_x_px: float
    tip_z_px: float
    confidence: float
    reason: str | None
    edge_minus_angle_deg: float
    angle_from: str


def rest_axes(rest: Trace, base_px: np.ndarray, side: int) -> Axes:
    """The axes from the rest frame's trace and the curl side: x along the bottom edge where it leaves
    the clamp (a parabola through the edge's first half, read at the base, so an actuator that rests
    curled still gets the clamp's direction; a line where it rests straight), the origin on that edge
    across from ``base_px``."""
    edge = rest.edge(side)
    d = rest.direction
    n = np.array([-d[1], d[0]])
    rel = edge - base_px
    u, v = rel @ d, rel @ n
    first = (u <= u[0] + 0.5 * (u[-1] - u[0])) & (np.arange(len(u)) >= 1)  # the first station abuts the clamp
    if first.sum() >= 4:
        c2, c1, c0 = np.polyfit(u[first], v[first], 2)
        if abs(c2) * np.ptp(u[first]) ** 2 < REST_SAG_PX:  # straight at rest: a line is read more surely
            c1, c0 = np.polyfit(u[first], v[first], 1)
    else:
        c1, c0 = 0.0, float(np.median(v))
    x_hat = d + c1 * n
    x_hat /= np.linalg.norm(x_hat)
    z_hat = -side * np.array([-x_hat[1], x_hat[0]])
    origin = base_px + c0 * n
    length = float(np.hypot(*(edge[0] - origin)) + _edge_length(rest, side))  # along the edge: a curled rest too
    thickness = float(np.median(np.hypot(*(rest.edge_a_px - rest.edge_b_px).T)))
    return Axes(origin, x_hat, z_hat, side, length, thickness)


def end_tangent_turn(trace: Trace, side: int, span_px: float, direction: np.ndarray,
                     cut_px: float = 0.0) -> tuple[float, float]:
    """The bottom edge's direction at its end as a turn from rest (rad, unwrapped as the trace is) and
    how far the edge strays from that (deg, RMS): the edge's direction along its last ``span_px``
    fitted as a straight line in its arc length (a constant curvature; segments far off it, a
    chamber's bump or a plate's corner, left out) and read at the end (``direction``: the rest
    direction the turns count from). The last ``cut_px`` are left out of the fit: there the
    cross-sections run out through the end face rather than the edge."""
    edge = trace.edge_a_px if side > 0 else trace.edge_b_px
    seg = np.diff(edge, axis=0)
    length = np.hypot(*seg.T)
    ok = length > 0.5
    seg, length = seg[ok], length[ok]
    if len(seg) < 3:
        return (float(trace.turn_rad[-1]) if len(trace.turn_rad) else 0.0), 90.0
    rest = math.atan2(direction[1], direction[0])
    angle = np.unwrap(np.arctan2(seg[:, 1], seg[:, 0]) - rest)
    angle += 2 * np.pi * round((float(trace.turn_rad[-1]) - angle[-1]) / (2 * np.pi))  # as the march's turn
    s_mid = np.cumsum(length) - 0.5 * length
    s_end = s_mid[-1] + 0.5 * length[-1]
    use = (s_mid >= s_end - cut_px - span_px) & (s_mid <= s_end - cut_px)
    if use.sum() < 3:
        return float(angle[-1]), 90.0
    for _ in range(2):
        slope, intercept = np.polyfit(s_mid[use], angle[use], 1, w=length[use])
        resid = np.abs(angle - (intercept + slope * s_mid))
        keep = use & (resid <= max(math.radians(4), 3 * float(np.median(resid[use]))))
        if keep.sum() < 3 or keep.sum() == use.sum():
            break
        use = keep
    rms = math.degrees(float(np.sqrt(np.average(resid[use] ** 2, weights=length[use]))))
    return float(intercept + slope * s_end), rms


def read_frame(trace: Trace, rest: Trace, axes: Axes, width_px: float,
               match: tuple[float, float] | None = None) -> Reading:
    """The bend angle (deg, positive curling), the tip (px in pnmold's axes) and the confidence.

    The angle is the end face's turn (its outline's chord, corner to corner) where its readings
    agree and the bottom edge's direction at the end does not contradict it. Where the face cannot
    be read at rest (an end plate, markers on the end: :func:`reads_by_look`), the turn of the end's
    look (``match``: turn in rad as the trace counts it, and its score, :mod:`.endmatch`) is read
    instead, in every frame, with a lower confidence."""
    side = axes.side
    span = max(1.5 * width_px, 0.25 * axes.length_px)
    d, x = trace.direction, axes.x_hat
    offset = math.atan2(d[0] * x[1] - d[1] * x[0], float(d @ x))  # the clamp's direction from the clicks'
    turn, rms = end_tangent_turn(trace, side, span, trace.direction, END_CUT_WIDTHS * width_px)
    by_edge = math.degrees(side * (turn - offset))
    by_face = math.degrees(side * (trace.end_turn_rad - offset))
    angle, how, quality, doubt = by_face, "face", 1.0, _face_doubt(trace, by_edge, by_face)
    if doubt:
        quality = 0.0
    if match is not None:
        angle, how = math.degrees(side * (match[0] - offset)), "look"
        quality, doubt = (0.55, None) if match[1] >= MATCH_SCORE else \
            (0.0, f"unsure: the end's look matches the first frame's poorly (correlation {match[1]:.2f})")
    corner = trace.end_a_px if side > 0 else trace.end_b_px
    tip_x, tip_z = axes.to_frame(corner)
    ratio = _edge_length(trace, side) / max(_edge_length(rest, side), 1e-9)
    merged = float(np.mean(trace.merged)) if len(trace.merged) else 1.0
    reason = _refusal(trace, ratio, merged, how == "look") or doubt
    length_score = 1.0 if how == "look" else float(np.clip(1 - abs(ratio - 1) / 0.4, 0.0, 1.0))
    merged_score = 1.0 if how == "look" else 1 - min(merged, 1.0) * 0.5
    confidence = 0.0 if reason else round(min(quality, length_score, merged_score), 3)
    if reason is None and confidence < 0.5:
        reason = f"unsure: the traced length is {ratio:.0%} of the length at rest"
    return Reading(angle, tip_x, tip_z, confidence, reason, by_edge - angle, how)


def _face_doubt(trace: Trace, by_edge: float, by_face: float) -> str | None:
    """Why the end face's reading is not trusted, or None."""
    if trace.face_spread_deg > FACE_SPREAD_DEG:
        return f"unsure: the end face's readings spread {trace.face_spread_deg:.1f} deg"
    if abs(by_edge - by_face) > EDGE_FACE_DEG + EDGE_FACE_SHARE * abs(by_face):
        return f"unsure: the end face and the bottom edge disagree by {abs(by_edge - by_face):.0f} deg"
    return None


def reads_by_look(rest: Trace, axes: Axes, width_px: float) -> bool:
    """True when the end cannot be read by its outline at rest (where the end face and the bottom edge must
    agree): an end cap, a plate or markers make its outline; then every frame is read by the end's look."""
    return read_frame(rest, rest, axes, width_px).reason is not None


def _smoothness(rms_deg: float) -> float:
    """1 while the bottom edge strays less than SMOOTH_DEG from a constant curvature, 0 at 3 times it."""
    return float(np.clip((3 * SMOOTH_DEG - rms_deg) / (2 * SMOOTH_DEG), 0.0, 1.0))


def rest_turn(rest: Trace, axes: Axes, width_px: float) -> float:
    """The end's turn at rest (rad, as the trace counts it): the end face's reading where it can be read,
    else the clamp's direction (an end that cannot be read at rest is taken as straight)."""
    d, x = rest.direction, axes.x_hat
    offset = math.atan2(d[0] * x[1] - d[1] * x[0], float(d @ x))
    if reads_by_look(rest, axes, width_px):
        return offset
    return offset + axes.side * math.radians(read_frame(rest, rest, axes, width_px).bend_angle_deg)


def _refusal(trace: Trace, ratio: float, merged: float, by_look: bool) -> str | None:
    """Why a trace is refused; read by its end's look, its outline may run on (a plate's arm)."""
    if trace.reason:
        return trace.reason
    if trace.at_border:
        return "out of the picture: the body reaches the picture's border"
    if by_look:
        return None if LOOK_RATIO_LIMITS[0] <= ratio <= LOOK_RATIO_LIMITS[1] else \
            f"body lost: traced {ratio:.0%} of its length at rest"
    if ratio < EDGE_RATIO_LIMITS[0]:
        return f"body lost: traced {ratio:.0%} of its length at rest (occluded, or it left its colour)"
    if ratio > EDGE_RATIO_LIMITS[1]:
        return f"body lost: the trace runs on to {ratio:.0%} of its length at rest (merged with something)"
    if merged > MERGED_SHARE:
        return f"occluded: {merged:.0%} of the body's cross-sections merge with something of its colour"
    return None


def _edge_length(trace: Trace, side: int) -> float:
    edge = trace.edge(side)
    return float(np.hypot(*np.diff(edge, axis=0).T).sum()) if len(edge) > 1 else 0.0
