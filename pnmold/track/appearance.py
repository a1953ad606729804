"""What the body looks like, learned from the first frame, and where it is in any frame.

The first frame shows the actuator at rest and the two clicks say where it lies: from the base
(where it leaves the clamp) to the tip. Its colour is sampled along that line, its width found by
walking out from the line until the colour changes, and a colour histogram (CIE Lab, smoothed) of
the body is set against one of its surroundings (within about a body length, the clamp's side of
the base left out: the clamp is expected to look like the body). A pixel's probability of being
body is the histograms' ratio; a colour seen in neither is background. What looked like the body in
the first frame but lies outside it (the clamp, tubing, a dark cable) is *clutter*: in later frames a
pixel that still looks as it did then is not body. The mask keeps the connected part at the base,
closes the holes markers and ribs make and opens away thin lines (a grid, a hair).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pnmold.errors import UsageError

#: Lab histogram bins per channel
BINS = 32
#: a pixel of the clutter is still clutter when its Lab colour moved less than this since the first frame
CLUTTER_TOLERANCE = 18.0
#: a shadow darkens the surroundings' lightness to these shares of it
SHADOW_FACTORS = (0.6, 0.7, 0.8, 0.9)
#: GrabCut's rounds per frame
GRABCUT_ITERATIONS = 3


@dataclass(frozen=True, eq=False)
class Appearance:
    """The body as the first frame shows it.

    ``ratio``: P(body | Lab colour bin); ``half_width_a_px``/``_b_px``: the body's extent either side
    of the base-tip line (``a``: toward the normal ``normal`` = direction turned +90 degrees in image
    coordinates); ``clutter``: body-like pixels of the first frame outside the body; ``reference``:
    the first frame in Lab, to tell clutter that stayed from body that moved onto it."""

    base_px: np.ndarray
    tip_px: np.ndarray
    direction: np.ndarray
    normal: np.ndarray
    length_px: float
    half_width_a_px: float
    half_width_b_px: float
    ratio: np.ndarray
    clutter: np.ndarray
    reference: np.ndarray
    contrast: float

    @property
    def width_px(self) -> float:
        return self.half_width_a_px + self.half_width_b_px

    def probability(self, image: np.ndarray) -> np.ndarray:
        """P(body) per pixel of a BGR frame, float32 in [0, 1]."""
        import cv2

        lab = cv2.cvtColor(image, cv2.COLOR_BGR2LAB)
        idx = (lab.astype(np.int32) * BINS) // 256
        p = self.ratio[idx[..., 0], idx[..., 1], idx[..., 2]].astype(np.float32)
        p = cv2.GaussianBlur(p, (0, 0), 1.0)
        if self.clutter.any():
            moved = np.linalg.norm(lab.astype(np.float32) - self.reference, axis=2) > CLUTTER_TOLERANCE
            p[self.clutter & ~moved] = 0.0
        return p

    def mask(self, image: np.ndarray) -> np.ndarray:
        """The body's mask in a frame (uint8 0/1): the colour's probability refined by a graph cut
        (GrabCut: colour models of the frame itself and a cost on cutting between like pixels, so a
        shadow as dark as the body but parted from it by an edge stays out), the part connected to
        the base, holes closed."""
        import cv2

        raw = _graph_cut(image, self.probability(image), self.base_px, 1.5 * self.length_px + 2 * self.width_px)
        thin = max(1, int(round(0.06 * self.width_px)))
        fill = max(3, int(round(0.3 * self.width_px)) | 1)
        opened = cv2.morphologyEx(raw, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE,
                                                                                   (2 * thin + 1,) * 2))
        closed = cv2.morphologyEx(opened, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE,
                                                                                      (fill, fill)))
        return _part_at(closed, self.base_px + self.direction * 0.1 * self.length_px, 0.5 * self.width_px)


def _graph_cut(image: np.ndarray, prob: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """GrabCut started from the colour's probability, within a square of ``radius`` around ``centre``
    (pixels the colour calls surely background stay so); 0/1 uint8 of the whole frame."""
    import cv2

    h, w = prob.shape
    x0, y0 = max(0, int(centre[0] - radius)), max(0, int(centre[1] - radius))
    x1, y1 = min(w, int(centre[0] + radius) + 1), min(h, int(centre[1] + radius) + 1)
    p = prob[y0:y1, x0:x1]
    seeds = np.full(p.shape, cv2.GC_PR_BGD, np.uint8)
    seeds[p > 0.5] = cv2.GC_PR_FGD
    seeds[p < 0.05] = cv2.GC_BGD
    out = np.zeros((h, w), np.uint8)
    if (seeds == cv2.GC_PR_FGD).sum() < 10 or (seeds != cv2.GC_PR_FGD).sum() < 10:
        out[y0:y1, x0:x1] = p > 0.5
        return out
    models = (np.zeros((1, 65)), np.zeros((1, 65)))
    cv2.setRNGSeed(0)  # GrabCut seeds its colour models with k-means: the same frame, the same mask
    cv2.grabCut(np.ascontiguousarray(image[y0:y1, x0:x1]), seeds, None, *models, GRABCUT_ITERATIONS,
                cv2.GC_INIT_WITH_MASK)
    out[y0:y1, x0:x1] = (seeds == cv2.GC_FGD) | (seeds == cv2.GC_PR_FGD)
    return out


def _part_at(mask: np.ndarray, point: np.ndarray, radius: float) -> np.ndarray:
    """The connected parts of ``mask`` that reach within ``radius`` of ``point``."""
    import cv2

    count, labels = cv2.connectedComponents(mask, connectivity=8)
    if count <= 1:
        return mask
    h, w = mask.shape
    x0, y0 = int(round(point[0])), int(round(point[1]))
    r = max(2, int(radius))
    window = labels[max(0, y0 - r):min(h, y0 + r + 1), max(0, x0 - r):min(w, x0 + r + 1)]
    keep = np.unique(window[window > 0])
    return np.isin(labels, keep).astype(np.uint8)


def check_point(name: str, point: tuple[float, float], size_px: tuple[int, int]) -> np.ndarray:
    """A clicked pixel, refused (UsageError naming the option) when it is not on the picture."""
    w, h = size_px
    x, y = point
    if not (0 <= x < w and 0 <= y < h):
        raise UsageError(f"--{name}: ({x:g}, {y:g}) is outside the first frame, {w}x{h} px "
                         "(x from the left, y from the top)")
    return np.array([float(x), float(y)])


def learn_appearance(image: np.ndarray, base_px: np.ndarray, tip_px: np.ndarray) -> Appearance:
    """The body's :class:`Appearance` from the first frame and the two clicks."""
    import cv2

    axis = tip_px - base_px
    length = float(np.hypot(*axis))
    if length < 10:
        raise UsageError(f"--tip: {length:.1f} px from --base; click the base and the tip of the body at rest "
                         "(at least 10 px apart)")
    d = axis / length
    n = np.array([-d[1], d[0]])
    lab = cv2.cvtColor(image, cv2.COLOR_BGR2LAB).astype(np.float32)
    centre, spread = _line_colour(lab, base_px, d, length)
    wa, wb = _half_widths(lab, base_px, d, n, length, centre, spread)
    if wa + wb < 3:
        raise UsageError("--base/--tip: the line between them does not run along a body that stands out from "
                         "its surroundings (the body found is less than 3 px wide); click the body's ends")
    body = _box(lab.shape[:2], base_px, d, n, length, (0.05, 0.95), (-0.75 * wb, 0.75 * wa))
    near = _box(lab.shape[:2], base_px, d, n, length, (-0.05, 1.6), (-wb - 1.2 * length, wa + 1.2 * length))
    grown = _box(lab.shape[:2], base_px, d, n, length, (-0.06, 1.06), (-1.25 * wb - 3, 1.25 * wa + 3))
    ring = near & ~grown
    if ring.sum() < 50:
        raise UsageError("--base/--tip: the body fills the picture; the camera must see around it")
    ratio, contrast = _colour_ratio(lab, body, ring)
    model = Appearance(base_px, tip_px, d, n, length, wa, wb, ratio, np.zeros(lab.shape[:2], bool), lab, contrast)
    first = model.probability(image) > 0.5
    clutter = cv2.dilate((first & ~grown).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    return Appearance(base_px, tip_px, d, n, length, wa, wb, ratio, clutter & ~grown, lab, contrast)


def _line_colour(lab: np.ndarray, base: np.ndarray, d: np.ndarray, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Median Lab colour along the middle of the base-tip line, and a robust spread per channel."""
    s = np.linspace(0.1 * length, 0.9 * length, max(20, int(length)))
    pts = base[None] + s[:, None] * d[None]
    samples = _sample(lab, pts)
    centre = np.median(samples, axis=0)
    spread = 1.4826 * np.median(np.abs(samples - centre), axis=0)
    return centre, np.maximum(spread, [4.0, 3.0, 3.0])


def _half_widths(lab, base, d, n, length, centre, spread) -> tuple[float, float]:
    """The body's extent either side of the line: at stations along it, walking out from the line, the
    first step of the colour's distance from the body's (medians over a few pixels either side, so a
    glint or a marker is no step) that is at least half the profile's largest; medians over the
    stations."""
    reach = int(max(12, 1.2 * length))
    win = int(np.clip(length / 10, 3, 12))
    t = np.arange(0, reach + win, dtype=float)
    out = {1: [], -1: []}
    for s in np.linspace(0.15, 0.85, 15) * length:
        for side in (1, -1):
            pts = base[None] + s * d[None] + side * t[:, None] * n[None]
            dist = np.linalg.norm((_sample(lab, pts) - centre) / spread, axis=1)
            windows = np.lib.stride_tricks.sliding_window_view(dist, win)
            med = np.median(windows, axis=1)
            step = np.full(len(t), -np.inf)
            step[win:len(med)] = med[win:] - med[:len(med) - win]
            strong = max(0.8, np.max(step) / 2)
            peaks = [i for i in range(win, len(med) - 1)
                     if step[i] >= strong and step[i] >= step[i - 1] and step[i] >= step[i + 1]]
            out[side].append(float(peaks[0]) if peaks else float(reach))
    return float(np.median(out[1])), float(np.median(out[-1]))


def _sample(img: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Bilinear samples of ``img`` (H, W[, C]) at (x, y) points; outside the picture: the nearest edge."""
    import cv2

    mx = pts[:, 0].astype(np.float32)[None]
    my = pts[:, 1].astype(np.float32)[None]
    out = cv2.remap(img, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out[0]


def _box(shape, base, d, n, length, along, across) -> np.ndarray:
    """Pixels whose coordinates (s along ``d`` from the base, t along ``n``) lie in the box
    ``along`` (fractions of the length) x ``across`` (px)."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w]
    dx, dy = xx - base[0], yy - base[1]
    s = dx * d[0] + dy * d[1]
    t = dx * n[0] + dy * n[1]
    return (s >= along[0] * length) & (s <= along[1] * length) & (t >= across[0]) & (t <= across[1])


def _colour_ratio(lab: np.ndarray, body: np.ndarray, ring: np.ndarray) -> tuple[np.ndarray, float]:
    """P(body | colour) from the two smoothed histograms, and how well they separate (0..1). The
    surroundings count also as they look in a shadow (their lightness times each of SHADOW_FACTORS), so
    a shadow the body casts where there was none in the first frame is not taken for the body."""
    from scipy.ndimage import gaussian_filter

    idx = (np.clip(lab, 0, 255).astype(np.int32) * BINS) // 256

    def hist(mask):
        h = np.zeros((BINS,) * 3)
        np.add.at(h, (idx[..., 0][mask], idx[..., 1][mask], idx[..., 2][mask]), 1.0)
        return gaussian_filter(h, 1.0, mode="constant") / max(1, mask.sum())

    hf, hb = hist(body), hist(ring)
    cells = idx[ring]
    for f in SHADOW_FACTORS:  # the surroundings in shadow: darker, the same hue
        dark = cells.copy()
        dark[:, 0] = (lab[ring][:, 0] * f).astype(np.int32) * BINS // 256
        h = np.zeros((BINS,) * 3)
        np.add.at(h, (dark[:, 0], dark[:, 1], dark[:, 2]), 1.0)
        hb += gaussian_filter(h, 1.0, mode="constant") / max(1, len(cells)) / len(SHADOW_FACTORS)
    floor = 1e-6
    ratio = np.where(hf + hb > floor, hf / np.maximum(hf + hb, floor), 0.0)
    pf = ratio[idx[..., 0][body], idx[..., 1][body], idx[..., 2][body]]
    pb = ratio[idx[..., 0][ring], idx[..., 1][ring], idx[..., 2][ring]]
    contrast = float(np.mean(pf > 0.5) - np.mean(pb > 0.5))
    return ratio.astype(np.float32), contrast
