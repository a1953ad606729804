"""The body's centre line in one frame: marched from the base along the mask.

From the base, a step along the current direction, then a cross-section across it: the run of
body pixels around the predicted point gives the two edges (to a fraction of a pixel, on the
mask smoothed) and their middle, the next centre point. The direction follows the last centre
points, its turn per step bounded by the body's width (a thick body cannot fold sharper than
that). A run much wider than the body at rest (the body merged with something of its colour) keeps
the edge that continues the previous one. The march ends where no body is left ahead: the free
end, found to a fraction of a pixel along lines parallel to the direction across the last
cross-section, which also give the end face's slope. A march that reaches the picture's border
says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: the march's step as a fraction of the body's width at rest
STEP_WIDTHS = 0.25
#: a cross-section this much wider than the body at rest has merged with something
MERGED_WIDTHS = 1.6
#: a cross-section this much narrower is no longer the body (a corner, a cable)
THIN_WIDTHS = 0.3
#: outline points whose outward normal lies within this of the end's direction belong to the end face;
#: the face is read with each and the readings must agree
FACE_CONES_DEG = (40.0, 45.0, 50.0)
#: rounds of the end face's fit, each from the last one's direction
FACE_ROUNDS = 6


@dataclass(frozen=True, eq=False)
class Trace:
    """A frame's traced body, in pixels (x right, y down).

    ``centre_px``, ``edge_a_px``, ``edge_b_px``: (k, 2) points per cross-section (edge ``a`` on the
    side of the normal, the direction turned +90 degrees in image coordinates); ``turn_rad``: the
    direction's turn from the rest direction at each cross-section, unwrapped (positive from the
    direction toward the normal); ``merged``: cross-sections that met something of the body's colour;
    ``end_*``: the free end's middle and corners (where each edge stops); ``end_turn_rad``: the end
    face's normal's turn;
    ``direction``: the rest direction the turns count from; ``reason``: why the trace cannot be used
    (None when it can); ``face_spread_deg``: how far the end face's readings from its outline spread."""

    centre_px: np.ndarray
    edge_a_px: np.ndarray
    edge_b_px: np.ndarray
    turn_rad: np.ndarray
    merged: np.ndarray
    end_px: np.ndarray
    end_a_px: np.ndarray
    end_b_px: np.ndarray
    end_turn_rad: float
    at_border: bool
    direction: np.ndarray
    reason: str | None = None
    face_spread_deg: float = math.inf

    def edge(self, side: int) -> np.ndarray:
        """The edge on side +1 (``a``) or -1 (``b``), the free end's corner appended (edge points the
        end face cuts off left out)."""
        pts = self.edge_a_px if side > 0 else self.edge_b_px
        corner = self.end_a_px if side > 0 else self.end_b_px
        ahead = _rot(self.direction, self.end_turn_rad)
        keep = np.ones(len(pts), bool)
        keep[-4:] = (pts[-4:] - corner) @ ahead < -1.0
        return np.vstack([pts[keep], corner[None]])


def _profile(field: np.ndarray, point: np.ndarray, across: np.ndarray, t: np.ndarray) -> np.ndarray:
    import cv2

    pts = point[None] + t[:, None] * across[None]
    mx = pts[:, 0].astype(np.float32)[None]
    my = pts[:, 1].astype(np.float32)[None]
    return cv2.remap(field, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)[0]


def _crossing(t: np.ndarray, v: np.ndarray, i: int, j: int) -> float:
    """Where the profile crosses 0.5 between samples i (inside) and j (outside)."""
    a, b = v[i], v[j]
    return float(t[i] + (t[j] - t[i]) * (a - 0.5) / (a - b)) if a != b else float(t[i])


def cross_section(field, point, across, reach, near) -> tuple[float, float] | None:
    """The run of body (field > 0.5) across ``point`` along ``across``: its edges (t_lo, t_hi) in px,
    the run holding the sample nearest to 0 within ``near`` px; None when there is none."""
    step = 0.5
    t = np.arange(-reach, reach + step, step)
    v = _profile(field, point, across, t)
    inside = v > 0.5
    if not inside.any():
        return None
    cand = np.flatnonzero(inside)
    k = cand[np.argmin(np.abs(t[cand]))]
    if abs(t[k]) > near:
        return None
    lo = k
    while lo > 0 and inside[lo - 1]:
        lo -= 1
    hi = k
    while hi < len(t) - 1 and inside[hi + 1]:
        hi += 1
    t_lo = _crossing(t, v, lo, lo - 1) if lo > 0 else float(t[0])
    t_hi = _crossing(t, v, hi, hi + 1) if hi < len(t) - 1 else float(t[-1])
    return t_lo, t_hi


def _rot(v: np.ndarray, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def trace_body(mask: np.ndarray, start_px: np.ndarray, direction: np.ndarray, width_px: float,
               max_length_px: float) -> Trace:
    """March the centre line of ``mask`` (0/1) from ``start_px`` (the base's middle) along ``direction``."""
    import cv2

    field = cv2.GaussianBlur(mask.astype(np.float32), (0, 0), 0.7)
    h, w = mask.shape
    step = max(1.0, STEP_WIDTHS * width_px)
    max_turn = step / (0.45 * width_px)
    p, turn = start_px.astype(float), 0.0
    d0 = direction / np.linalg.norm(direction)
    n0 = np.array([-d0[1], d0[0]])
    centres, ea, eb, turns, merged = [], [], [], [], []
    prev = (-0.5 * width_px, 0.5 * width_px)
    at_border, length = False, 0.0
    while length < max_length_px:
        d = _rot(d0, turn)
        n = _rot(n0, turn)
        q = p + step * d
        if not (1 <= q[0] < w - 2 and 1 <= q[1] < h - 2):
            at_border = True
            break
        run = cross_section(field, q, n, MERGED_WIDTHS * 1.5 * width_px, 0.5 * width_px)
        if run is None or run[1] - run[0] < THIN_WIDTHS * width_px:
            break
        lo, hi = run
        wide = hi - lo > MERGED_WIDTHS * width_px
        if wide:  # keep the edge that continues the last one, the width as it was
            if abs(lo - prev[0]) <= abs(hi - prev[1]):
                hi = lo + (prev[1] - prev[0])
            else:
                lo = hi - (prev[1] - prev[0])
        c = q + 0.5 * (lo + hi) * n
        centres.append(c)
        ea.append(q + hi * n)
        eb.append(q + lo * n)
        merged.append(wide)
        prev = (lo - 0.5 * (lo + hi), hi - 0.5 * (lo + hi))
        length += float(np.hypot(*(c - p)))
        if len(centres) >= 2:
            seg = centres[-1] - centres[-2]
            new = float(np.arctan2(seg[1], seg[0]) - np.arctan2(d0[1], d0[0]))
            delta = (new - turn + np.pi) % (2 * np.pi) - np.pi
            turn += float(np.clip(delta, -max_turn, max_turn)) * (0.6 if len(centres) > 2 else 1.0)
        turns.append(turn)
        p = c
    return _finish(field, centres, ea, eb, turns, merged, d0, n0, width_px, at_border, step)


def _finish(field, centres, ea, eb, turns, merged, d0, n0, width_px, at_border, step) -> Trace:
    if len(centres) < 3:
        empty = np.zeros((0, 2))
        z = np.zeros(2)
        return Trace(empty, empty, empty, np.zeros(0), np.zeros(0, bool), z, z, z, 0.0, at_border, d0,
                     "body lost: no body along the base's direction (moved, hidden or out of the picture)")
    centres, ea, eb = np.array(centres), np.array(ea), np.array(eb)
    turn = turns[-1]
    d, n = _rot(d0, turn), _rot(n0, turn)
    c = centres[-1]
    face = _end_face(field, c, d, n, float((eb[-1] - c) @ n), float((ea[-1] - c) @ n), 3 * step)
    end_turn, out = turn, face is None
    for _ in range(2):  # again from just inside the end, across the end's own direction
        if face is None:
            break
        end, _, _, slope = face
        end_turn = turn - float(np.arctan(slope))
        d, n = _rot(d0, end_turn), _rot(n0, end_turn)
        q = end - max(2.0, 0.1 * width_px) * d
        run = cross_section(field, q, n, MERGED_WIDTHS * width_px, 0.5 * width_px)
        if run is None:
            break
        refined = _end_face(field, q, d, n, run[0], run[1], max(6.0, 0.3 * width_px))
        if refined is None:
            break
        face, turn = refined, end_turn
    if face is None:
        end, end_a, end_b = c, ea[-1], eb[-1]
    else:
        end, end_a, end_b, slope = face
        end_turn = turn - float(np.arctan(slope))
    face_spread = math.inf
    outline = None if face is None else _face_by_outline(field, end, end_turn, d0, width_px)
    if outline is not None:
        end_turn, face_spread, middle = outline
        ahead = _rot(d0, end_turn)
        end_a = _corner_on_face(ea, middle, ahead, end_a)
        end_b = _corner_on_face(eb, middle, ahead, end_b)
        end = middle
    else:
        end_a = _corner(field, ea, eb, end_a)
        end_b = _corner(field, eb, ea, end_b)
    h, w = field.shape
    pts = np.vstack([ea, eb, end_a[None], end_b[None]])
    near_border = (pts[:, 0] < 1.5) | (pts[:, 1] < 1.5) | (pts[:, 0] > w - 2.5) | (pts[:, 1] > h - 2.5)
    at_border = at_border or out or bool(near_border.any())
    return Trace(centres, ea, eb, np.array(turns), np.array(merged), end, end_a, end_b, float(end_turn), at_border,
                 d0, face_spread_deg=float(face_spread))


def _face_by_outline(field: np.ndarray, end: np.ndarray, turn: float, d0: np.ndarray,
                     width_px: float) -> tuple[float, float, np.ndarray] | None:
    """The end face from the mask's outline, read with each cone of FACE_CONES_DEG: the face normal's
    turn (their median), how far the readings spread (deg) and the face's middle (px); None when too few
    points are found."""
    import cv2

    mask = (field > 0.5).astype(np.uint8)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return None
    pts = np.vstack([c[:, 0, :] for c in contours]).astype(float)
    near = pts[np.hypot(*(pts - end).T) <= 0.8 * width_px]
    if len(near) < 6:
        return None
    gy = cv2.Sobel(field, cv2.CV_32F, 0, 1, ksize=3)
    gx = cv2.Sobel(field, cv2.CV_32F, 1, 0, ksize=3)
    xi, yi = near[:, 0].astype(int), near[:, 1].astype(int)
    outward = -np.column_stack([gx[yi, xi], gy[yi, xi]])
    outward /= np.maximum(np.hypot(*outward.T), 1e-9)[:, None]
    found = [f for f in (_face_turn(near, outward, end, turn, d0, width_px, cone) for cone in FACE_CONES_DEG)
             if f is not None]
    if len(found) < 2:
        return None
    turns = [f[0] for f in found]
    middle = found[int(np.argsort(turns)[len(turns) // 2])][1]
    return float(np.median(turns)), math.degrees(max(turns) - min(turns)), middle


def _face_turn(near, outward, end, turn, d0, width_px, cone_deg) -> tuple[float, np.ndarray] | None:
    """The outline's points near the end whose outward normal lies within ``cone_deg`` of the end's
    direction are the end face; its direction is their chord, corner to corner (a bulging end wall's
    chord, not its bulge); FACE_ROUNDS rounds, each from the last one's direction."""
    centre = end
    for _ in range(FACE_ROUNDS):
        ahead = _rot(d0, turn)
        pick = (outward @ ahead >= math.cos(math.radians(cone_deg))) & \
            (np.hypot(*(near - centre).T) <= 0.7 * width_px)
        if pick.sum() < 6:
            return None
        sel = near[pick]
        centre = sel.mean(axis=0)
        _, _, vt = np.linalg.svd(sel - centre, full_matrices=False)
        order = np.argsort((sel - centre) @ vt[0])
        k = max(2, len(sel) // 10)
        chord = sel[order[-k:]].mean(axis=0) - sel[order[:k]].mean(axis=0)
        normal = np.array([-chord[1], chord[0]]) / max(float(np.hypot(*chord)), 1e-9)
        normal = normal if normal @ ahead > 0 else -normal
        turn += math.atan2(ahead[0] * normal[1] - ahead[1] * normal[0], float(ahead @ normal))
        middle = 0.5 * (sel[order[-k:]].mean(axis=0) + sel[order[:k]].mean(axis=0))
    return turn, middle


def _corner_on_face(edge: np.ndarray, middle: np.ndarray, ahead: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Where an edge meets the end face's line (through ``middle``, normal ``ahead``): its last stretch
    behind the face, carried on straight to the face."""
    dist = (edge - middle) @ ahead
    behind = np.flatnonzero(dist < -1.0)
    if len(behind) < 2:
        return fallback
    i = int(behind[-1])
    j = int(behind[-2]) if i == behind[-1] and len(behind) >= 2 else i - 1
    step = edge[i] - edge[j]
    along = float(step @ ahead)
    if along <= 1e-6:
        return fallback
    return edge[i] + (-dist[i] / along) * step


def _corner(field: np.ndarray, edge: np.ndarray, other: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Where an edge ends: from its last point along its own last direction (just inside the body)
    until the body stops; ``fallback`` (the end face's corner) when the edge is too short to say."""
    if len(edge) < 3:
        return fallback
    ahead = edge[-1] - edge[-3]
    norm = float(np.hypot(*ahead))
    if norm < 1e-6:
        return fallback
    ahead = ahead / norm
    inward = other[-1] - edge[-1]
    inward = inward / max(float(np.hypot(*inward)), 1e-6)
    inset = 1.5
    s = np.arange(0.0, 3.0 * norm + 0.25, 0.25)
    v = _profile(field, edge[-1] + inset * inward, ahead, s)
    gone = np.flatnonzero(v < 0.5)
    if gone.size == 0 or gone[0] == 0:
        return fallback
    i = int(gone[0])
    return edge[-1] + _crossing(s, v, i - 1, i) * ahead


def _end_face(field, c, d, n, t_b, t_a, reach):
    """The free end beyond the cross-section at ``c`` (edges at ``t_b`` and ``t_a`` along ``n``): where the
    body stops along lines parallel to ``d`` across it; a line through those points (s = s0 + slope * t)
    gives the end's middle, its corners on the two edges and the end face's slope. None when the body
    does not end within ``reach`` or runs past the picture's border."""
    h, w = field.shape
    ts = np.linspace(t_b + 0.12 * (t_a - t_b), t_a - 0.12 * (t_a - t_b), 11)
    s = np.arange(0.0, reach + 0.5, 0.25)
    ends = []
    for t in ts:
        v = _profile(field, c + t * n, d, s)
        gone = np.flatnonzero(v < 0.5)
        if gone.size == 0:
            continue
        i = int(gone[0])
        ends.append((t, _crossing(s, v, i - 1, i) if i > 0 else 0.0))
        tip = c + t * n + s[i] * d
        if not (1 <= tip[0] < w - 2 and 1 <= tip[1] < h - 2):
            return None
    if len(ends) < 4:
        return None
    e = np.array(ends)
    slope, s0 = np.polyfit(e[:, 0], e[:, 1], 1)
    resid = np.abs(e[:, 1] - (s0 + slope * e[:, 0]))
    keep = resid <= max(1.0, 2.5 * np.median(resid))
    if keep.sum() >= 4:
        slope, s0 = np.polyfit(e[keep, 0], e[keep, 1], 1)
    end = c + s0 * d
    corner_a = c + t_a * n + (s0 + slope * t_a) * d
    corner_b = c + t_b * n + (s0 + slope * t_b) * d
    return end, corner_a, corner_b, float(slope)
