"""Millimetres per pixel: given, measured on a grid behind the actuator, or from the free length.

The grid (``--grid-mm``, the size of its squares) is found in the first frame: the picture, the body
and everything of its colour masked out, is high-passed and autocorrelated (the mask's own
autocorrelation divided out); the grid's two shortest lattice vectors are the strongest peaks near
the origin, each refined from the peaks at its multiples to a fraction of a pixel. Their mean length
is one square. A picture without a periodic pattern is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pnmold.errors import UsageError

#: a lattice peak must reach this share of the zero-lag autocorrelation to count as a grid
GRID_PEAK = 0.12
#: grid squares between this many pixels
GRID_PERIOD_PX = (4.0, 80.0)


@dataclass(frozen=True)
class Scale:
    """mm per pixel and where it came from: ``source`` is ``mm-per-px`` (given), ``grid`` or
    ``free-length`` (the design's or the given free length over the traced length at rest);
    ``words`` says it for a person."""

    mm_per_px: float
    source: str
    words: str


@dataclass(frozen=True)
class Grid:
    """The grid found: its two lattice vectors (px) and its square's side in px (their mean length)."""

    v1_px: tuple[float, float]
    v2_px: tuple[float, float]
    period_px: float
    strength: float

    @property
    def skew(self) -> float:
        """How unequal the two sides are (0: square)."""
        a, b = math.hypot(*self.v1_px), math.hypot(*self.v2_px)
        return abs(a - b) / max(a, b)


def find_grid(image: np.ndarray, exclude: np.ndarray) -> Grid:
    """The grid behind the actuator in a BGR frame, ``exclude`` (bool) masked out; UsageError when
    there is none."""
    import cv2

    gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY).astype(np.float32)
    high = gray - cv2.GaussianBlur(gray, (0, 0), 6.0)
    keep = (~exclude).astype(np.float32)
    keep = cv2.erode(keep, np.ones((5, 5), np.uint8))
    if keep.sum() < 2000:
        raise UsageError("--grid-mm: too little background around the body to find the grid on")
    auto = _autocorrelation(high * keep, keep)
    peaks = _peaks(auto)
    if not peaks:
        raise UsageError("--grid-mm: no grid found in the first frame (no periodic pattern around the body); "
                         "give --scale-mm-per-px or --free-length-mm instead")
    v1 = peaks[0][1]
    others = [(v, p) for v, p in peaks[1:] if 55 <= _angle_deg(p, v1) <= 125
              and 0.7 <= math.hypot(*p) / math.hypot(*v1) <= 1.4]
    if not others:
        raise UsageError("--grid-mm: found lines in one direction only, not a grid of squares; give "
                         "--scale-mm-per-px or --free-length-mm instead")
    v2 = others[0][1]
    r1, r2 = _refine(auto, v1), _refine(auto, v2)
    period = 0.5 * (math.hypot(*r1) + math.hypot(*r2))
    return Grid(tuple(map(float, r1)), tuple(map(float, r2)), float(period), float(peaks[0][0]))


def _autocorrelation(signal: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Normalised autocorrelation, zero lag at the centre, the mask's overlap divided out."""
    h, w = signal.shape
    shape = (2 * h, 2 * w)
    fs = np.fft.rfft2(signal, shape)
    fm = np.fft.rfft2(mask, shape)
    num = np.fft.fftshift(np.fft.irfft2(fs * np.conj(fs), shape))
    den = np.fft.fftshift(np.fft.irfft2(fm * np.conj(fm), shape))
    auto = np.where(den > 0.25 * den.max(), num / np.maximum(den, 1e-9), 0.0)
    centre = auto[h, w]
    return auto / centre if centre > 0 else auto


def _peaks(auto: np.ndarray) -> list[tuple[float, np.ndarray]]:
    """Local maxima near the origin above GRID_PEAK, the nearest strong ones first: (height, lag (x, y))."""
    from scipy.ndimage import maximum_filter

    h, w = auto.shape
    cy, cx = h // 2, w // 2
    r = int(GRID_PERIOD_PX[1] * 1.5)
    win = auto[cy - r:cy + r + 1, cx - r:cx + r + 1]
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    rad = np.hypot(xx, yy)
    local = (win == maximum_filter(win, size=5)) & (rad >= GRID_PERIOD_PX[0]) & (rad <= GRID_PERIOD_PX[1])
    local &= win >= GRID_PEAK
    if not local.any():
        return []
    top = win[local].max()
    found = [(float(win[y, x]), np.array([xx[y, x], yy[y, x]], float))
             for y, x in np.argwhere(local)]
    strong = [f for f in found if f[0] >= 0.5 * top and (f[1][1] > 0 or (f[1][1] == 0 and f[1][0] > 0))]
    strong.sort(key=lambda f: math.hypot(*f[1]))
    return strong


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(np.clip(a @ b / (np.hypot(*a) * np.hypot(*b)), -1, 1)))


def _refine(auto: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The lattice vector from the peaks at its multiples, each to a fraction of a pixel."""
    h, w = auto.shape
    cy, cx = h // 2, w // 2
    ks, found = [], []
    k = 1
    while k * math.hypot(*v) < min(h, w) / 4 and k <= 8:
        guess = np.rint(v * k).astype(int)
        peak = _subpixel(auto, cx + guess[0], cy + guess[1])
        if peak is None:
            break
        found.append(peak - [cx, cy])
        ks.append(k)
        v = found[-1] / k
        k += 1
    if not found:
        return v
    ks = np.array(ks, float)
    pts = np.array(found)
    return (ks[:, None] * pts).sum(axis=0) / (ks ** 2).sum()


def _subpixel(auto: np.ndarray, x: int, y: int) -> np.ndarray | None:
    """The local maximum within 2 px of (x, y), refined by a parabola in each direction."""
    h, w = auto.shape
    if not (3 <= x < w - 3 and 3 <= y < h - 3):
        return None
    win = auto[y - 2:y + 3, x - 2:x + 3]
    j, i = np.unravel_index(int(np.argmax(win)), win.shape)
    y0, x0 = y - 2 + j, x - 2 + i
    if win[j, i] < 0.5 * GRID_PEAK:
        return None

    def vertex(a, b, c):
        den = a - 2 * b + c
        return 0.0 if den >= 0 else 0.5 * (a - c) / den

    dx = vertex(auto[y0, x0 - 1], auto[y0, x0], auto[y0, x0 + 1])
    dy = vertex(auto[y0 - 1, x0], auto[y0, x0], auto[y0 + 1, x0])
    return np.array([x0 + dx, y0 + dy])


def grid_scale(image: np.ndarray, exclude: np.ndarray, grid_mm: float) -> tuple[Scale, Grid]:
    """The scale from a grid of ``grid_mm`` squares found in ``image``."""
    if not grid_mm > 0:
        raise UsageError(f"--grid-mm: {grid_mm} is not a positive number")
    grid = find_grid(image, exclude)
    mm = grid_mm / grid.period_px
    return Scale(mm, "grid", f"grid of {grid_mm:g} mm squares found: {grid.period_px:.3f} px per square "
                 f"(sides differ by {100 * grid.skew:.1f} %)"), grid
