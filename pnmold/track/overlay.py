"""Frames with their tracking drawn, for a person to check at a glance, and a contact sheet of them.

On each frame: the traced outline's two edges (thin, yellow), the centre line (red), the base and
pnmold's axes at rest (green), the tip (blue), and a caption with the bend angle, the tip and the
confidence, or the reason the frame was skipped (in red).
"""

from __future__ import annotations

import numpy as np

from pnmold.track.tracker import TrackedFrame, Tracking

#: contact sheet: thumbnails per row and their width (px)
SHEET_COLUMNS = 4
THUMB_WIDTH_PX = 320


def encode_png(image: np.ndarray) -> bytes:
    import cv2

    ok, data = cv2.imencode(".png", image)
    if not ok:  # OpenCV returns a flag, not an error
        raise ValueError("OpenCV could not encode the overlay as PNG")
    return data.tobytes()


def _pts(a: np.ndarray) -> np.ndarray:
    return np.round(np.asarray(a, float) * 4).astype(np.int32).reshape(-1, 1, 2)


def draw_frame(image: np.ndarray, result: TrackedFrame, tracking: Tracking) -> np.ndarray:
    """``image`` (BGR) with the frame's trace, the base, the axes, the tip and a caption drawn."""
    import cv2

    out = image.copy()
    scale_px = max(1, round(max(image.shape[:2]) / 640))
    aa, shift = cv2.LINE_AA, 2
    t = result.trace
    if t is not None and len(t.centre_px):
        for edge in (t.edge(1), t.edge(-1)):
            cv2.polylines(out, [_pts(edge)], False, (0, 220, 255), scale_px, aa, shift)
        cv2.polylines(out, [_pts(np.vstack([t.centre_px, t.end_px[None]]))], False, (0, 0, 255), scale_px, aa, shift)
    ax = tracking.axes
    o = ax.origin_px
    arm = 0.25 * ax.length_px
    cv2.line(out, tuple(_pts(o)[0, 0]), tuple(_pts(o + arm * ax.x_hat)[0, 0]), (0, 200, 0), scale_px, aa, shift)
    cv2.line(out, tuple(_pts(o)[0, 0]), tuple(_pts(o + 0.5 * arm * ax.z_hat)[0, 0]), (0, 200, 0), scale_px, aa, shift)
    cv2.circle(out, tuple(_pts(o)[0, 0]), 4 * 3 * scale_px, (0, 200, 0), -1, aa, shift)
    if result.tip_px is not None:
        cv2.circle(out, tuple(_pts(result.tip_px)[0, 0]), 4 * 4 * scale_px, (255, 80, 0), -1, aa, shift)
    if result.accepted:
        text = (f"#{result.index}  {result.pressure_kpa:.4g} kPa  {result.bend_angle_deg:.1f} deg  tip "
                f"({result.tip_x_mm:.1f}, {result.tip_z_mm:.1f}) mm  conf {result.confidence:.2f}")
        colour = (0, 160, 0)
    else:
        text = f"#{result.index}  skipped: {result.reason}"
        colour = (0, 0, 255)
    _caption(out, text, colour, scale_px)
    return out


def _caption(image: np.ndarray, text: str, colour: tuple[int, int, int], scale_px: int) -> None:
    import cv2

    font, size = cv2.FONT_HERSHEY_SIMPLEX, 0.45 * scale_px
    width = image.shape[1] - 8
    lines, line = [], ""
    for word in text.split():
        trial = f"{line} {word}".strip()
        if cv2.getTextSize(trial, font, size, 1)[0][0] > width and line:
            lines.append(line)
            line = word
        else:
            line = trial
    lines.append(line)
    step = int(18 * scale_px)
    cv2.rectangle(image, (0, 0), (image.shape[1], step * len(lines) + 6), (255, 255, 255), -1)
    for i, text_line in enumerate(lines):
        cv2.putText(image, text_line, (4, step * (i + 1) - 2), font, size, colour, 1, cv2.LINE_AA)


def contact_sheet(drawn: list[tuple[np.ndarray, TrackedFrame]]) -> np.ndarray:
    """The drawn frames as thumbnails, :data:`SHEET_COLUMNS` a row, skipped ones framed in red."""
    import cv2

    if not drawn:
        return np.full((40, THUMB_WIDTH_PX, 3), 255, np.uint8)
    h, w = drawn[0][0].shape[:2]
    th = max(1, round(h * THUMB_WIDTH_PX / w))
    columns = min(SHEET_COLUMNS, len(drawn))
    rows = -(-len(drawn) // columns)
    sheet = np.full((rows * (th + 6), columns * (THUMB_WIDTH_PX + 6), 3), 255, np.uint8)
    for k, (image, result) in enumerate(drawn):
        thumb = cv2.resize(image, (THUMB_WIDTH_PX, th), interpolation=cv2.INTER_AREA)
        r, c = divmod(k, columns)
        y, x = r * (th + 6) + 3, c * (THUMB_WIDTH_PX + 6) + 3
        sheet[y:y + th, x:x + THUMB_WIDTH_PX] = thumb
        colour = (0, 160, 0) if result.accepted else (0, 0, 255)
        cv2.rectangle(sheet, (x - 2, y - 2), (x + THUMB_WIDTH_PX + 1, y + th + 1), colour, 2)
    return sheet
