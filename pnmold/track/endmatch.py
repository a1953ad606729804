"""The free end's turn by matching its look: the end at rest, turned, laid over the frame.

An end cap with a plate, markers or ribs on it does not end in a clean face, and its outline's
edges are not the body's; its look turns with it, though. The first frame's end (within about a
body width of its middle, the body's pixels and a rim around them) is turned through a range of
angles around a first guess and matched (normalised cross-correlation about the means) near the traced end of the
frame; the best angle, refined by a parabola, is the end's turn. A coarse pass on pictures halved,
then a fine one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: the coarse pass's half-range and step, and the fine pass's step (deg)
COARSE_RANGE_DEG = 60.0
COARSE_STEP_DEG = 3.0
FINE_STEP_DEG = 0.5
#: the patch's radius and how far its middle lies behind the end, in body widths at rest
PATCH_WIDTHS = 0.7
BACK_WIDTHS = 0.3


@dataclass(frozen=True, eq=False)
class EndPatch:
    """The end at rest: its grey values and weights (square, ``2 * radius + 1`` px), the turn it has at
    rest (rad) and where its middle lies behind the traced end (px along the end's direction)."""

    gray: np.ndarray
    weight: np.ndarray
    rest_turn_rad: float
    back_px: float

    @property
    def radius(self) -> int:
        return self.gray.shape[0] // 2


def _rot(v: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def _crop(img: np.ndarray, centre: np.ndarray, r: int) -> np.ndarray:
    import cv2

    m = np.float32([[1, 0, r - centre[0]], [0, 1, r - centre[1]]])
    return cv2.warpAffine(img, m, (2 * r + 1, 2 * r + 1), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def end_patch(gray: np.ndarray, mask: np.ndarray, end_px: np.ndarray, direction: np.ndarray, end_turn_rad: float,
              width_px: float) -> EndPatch:
    """The rest frame's end (``gray``: float32 picture, ``mask``: the body)."""
    import cv2

    r = max(6, int(round(PATCH_WIDTHS * width_px)))
    back = BACK_WIDTHS * width_px
    centre = end_px - back * _rot(direction, end_turn_rad)
    rim = max(1, int(round(0.08 * width_px)))
    grown = cv2.dilate(mask.astype(np.uint8), np.ones((2 * rim + 1,) * 2, np.uint8)).astype(np.float32)
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    disk = (np.hypot(xx, yy) <= r).astype(np.float32)
    return EndPatch(_crop(gray, centre, r), _crop(grown, centre, r) * disk, float(end_turn_rad), back)


def _best(gray: np.ndarray, patch: EndPatch, centre: np.ndarray, turns: np.ndarray, search: int,
          shrink: int) -> tuple[np.ndarray, np.ndarray]:
    """Match scores (one per turn) and their best offsets, on pictures shrunk ``shrink`` times."""
    import cv2

    r = patch.radius
    window = _crop(gray, centre, r + search)
    tmpl, weight = patch.gray, patch.weight
    if shrink > 1:
        size = (window.shape[1] // shrink, window.shape[0] // shrink)
        window = cv2.resize(window, size, interpolation=cv2.INTER_AREA)
    scores, offsets = [], []
    for turn in turns:
        deg = -math.degrees(turn - patch.rest_turn_rad)  # OpenCV turns counter-clockwise as seen
        rot = cv2.getRotationMatrix2D((r, r), deg, 1.0 / shrink)
        side = (2 * r) // shrink + 1
        rot[:, 2] += (side - 1) / 2 - r / shrink
        t = cv2.warpAffine(tmpl, rot, (side, side), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        w = cv2.warpAffine(weight, rot, (side, side), flags=cv2.INTER_LINEAR)
        if window.shape[0] < side or window.shape[1] < side or w.sum() < 10:
            scores.append(-1.0)
            offsets.append(np.zeros(2))
            continue
        res = cv2.matchTemplate(window, t, cv2.TM_CCOEFF_NORMED, mask=w)
        res = np.nan_to_num(res, nan=-1.0, posinf=-1.0, neginf=-1.0)
        j, i = np.unravel_index(int(np.argmax(res)), res.shape)
        scores.append(float(res[j, i]))
        offsets.append(np.array([i, j], float) * shrink - search)
    return np.array(scores), np.array(offsets)


def match_end_turn(gray: np.ndarray, patch: EndPatch, end_px: np.ndarray, direction: np.ndarray,
                   guess_rad: float) -> tuple[float, float]:
    """The end's turn (rad, as the trace counts it) in a frame and the match's score (0..1)."""
    r = patch.radius
    centre = end_px - patch.back_px * _rot(direction, guess_rad)
    search = max(3, r // 2)
    coarse = guess_rad + np.radians(np.arange(-COARSE_RANGE_DEG, COARSE_RANGE_DEG + 1e-9, COARSE_STEP_DEG))
    scores, offsets = _best(gray, patch, centre, coarse, search, 2)
    k = int(np.argmax(scores))
    best = coarse[k]
    centre = centre + offsets[k]
    fine = best + np.radians(np.arange(-COARSE_STEP_DEG, COARSE_STEP_DEG + 1e-9, FINE_STEP_DEG))
    scores, _ = _best(gray, patch, centre, fine, max(3, search // 3), 1)
    k = int(np.argmax(scores))
    turn = float(fine[k])
    if 0 < k < len(fine) - 1:
        a, b, c = scores[k - 1], scores[k], scores[k + 1]
        den = a - 2 * b + c
        if den < 0:
            turn += 0.5 * (a - c) / den * math.radians(FINE_STEP_DEG)
    return turn, float(scores[k])
