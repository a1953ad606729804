"""What a tracking writes: the recording (docs/recording-format.md), the JSON summary and the overlay
folder (each frame with its trace drawn, and a contact sheet).

The recording holds one row per accepted frame: ``bending`` (pressure, tip, bend angle, and the time
when the frames have one) or ``step`` (time, supply, pressure, bend angle, tip). Two extra columns,
``frame`` and ``confidence``, are kept and ignored by readers. The metadata say how it was measured:
``tip_origin: clamp``, ``bending_length_mm``, the scale and its source, the camera and the frames used;
a ``##`` comment line per skipped frame gives its reason.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pnmold.errors import UsageError
from pnmold.fsutil import staged_dir, write_json, write_text
from pnmold.recording import format_recording
from pnmold.track.media import Frame
from pnmold.track.tracker import Tracking

#: recording kinds a tracking writes
KINDS = ("bending", "step")


def recording_text(tracking: Tracking, kind: str = "bending", design: str | None = None,
                   orientation: str | None = None) -> str:
    """The recording of the accepted frames; UsageError when fewer than two were accepted or a step
    recording lacks times or the supply."""
    rows = tracking.accepted
    if kind not in KINDS:
        raise UsageError(f"--kind: {kind!r}; a tracking writes {' or '.join(KINDS)}")
    if len(rows) < 2:
        skipped = "; ".join(f"{f.name}: {f.reason}" for f in tracking.frames if not f.accepted)[:600]
        raise UsageError(f"FRAMES: {len(rows)} frame(s) accepted, a recording needs 2 or more ({skipped})")
    cols: dict[str, np.ndarray] = {}
    times = [f.time_s for f in rows]
    if kind == "step":
        if None in times:
            raise UsageError("--kind step: the frames have no times; give --fps or a video")
        if any(f.supply_kpa is None for f in rows):
            raise UsageError("--kind step: the pressure log has no supply column (supply_kpa, supply_bar, ...)")
        cols["time_s"] = np.array(times, float)
        cols["supply_kpa"] = np.array([f.supply_kpa for f in rows], float)
    cols["pressure_kpa"] = np.array([f.pressure_kpa for f in rows], float)
    cols["tip_x_mm"] = np.array([f.tip_x_mm for f in rows], float)
    cols["tip_z_mm"] = np.array([f.tip_z_mm for f in rows], float)
    cols["bend_angle_deg"] = np.array([f.bend_angle_deg for f in rows], float)
    if kind == "bending" and None not in times:
        cols["time_s"] = np.array(times, float)
    cols["frame"] = np.array([f.index for f in rows], float)
    cols["confidence"] = np.array([f.confidence for f in rows], float)
    meta = {}
    if design:
        meta["design"] = design
    if orientation:
        meta["orientation"] = orientation
    s = tracking.scale
    meta |= {"tip_origin": "clamp   pnmold's frame: x from the clamp along the rest direction, z away from the curl",
             "bending_length_mm": f"{tracking.bending_length_mm:.3f}   the bottom edge's length at rest, as traced",
             "scale_mm_per_px": f"{s.mm_per_px:.6g}", "scale_source": f"{s.source}   {s.words}",
             "camera": f"tracked   {tracking.footage.words()}",
             "frames_used": f"{len(rows)}   of {len(tracking.frames)} (the others: '## skipped' below)",
             "tracker": f"pnmold-track   base and tip clicked at {_xy(tracking.base_px)} and "
                        f"{_xy(tracking.tip_px)} px; curls {tracking.curl}"}
    text = format_recording(kind, cols, meta)
    notes = [f"## skipped frame {f.index} ({f.name}): {f.reason}" for f in tracking.frames if not f.accepted]
    if notes:
        head, sep, table = text.partition("\n" + ",".join(cols) + "\n")
        text = head + "\n" + "\n".join(notes) + sep + table
    return text


def _xy(point) -> str:
    return f"({point[0]:.0f},{point[1]:.0f})"


#: the summary beside an overlay's pictures (``pnmold report`` shows the contact sheet of an
#: overlay folder inside a build folder, with it)
OVERLAY_SUMMARY = "tracking.json"


def write_outputs(tracking: Tracking, frames: list[Frame] | None, recording: str | Path, *, kind: str = "bending",
                  design: str | None = None, orientation: str | None = None, json_path: str | Path | None = None,
                  overlay: str | Path | None = None) -> dict:
    """Write the overlay folder from ``frames`` (first: it shows why frames were skipped, so it is
    written even when too few were accepted for a recording), the recording and the JSON summary; the
    summary."""
    doc = tracking.to_json() | {"design": design, "kind": kind, "recording": str(recording),
                                "overlay": None if overlay is None else str(overlay)}
    if overlay is not None:
        from pnmold.track.overlay import contact_sheet, draw_frame, encode_png

        with staged_dir(overlay, "pnmold track overlay") as folder:
            drawn = []
            for frame, result in zip(frames or [], tracking.frames, strict=False):
                image = draw_frame(frame.image, result, tracking)
                (folder / f"frame_{frame.index:04d}.png").write_bytes(encode_png(image))
                drawn.append((image, result))
            (folder / "contact_sheet.png").write_bytes(encode_png(contact_sheet(drawn)))
            write_json(folder / OVERLAY_SUMMARY, doc)  # the build report's caption (pnmold report)
    text = recording_text(tracking, kind, design, orientation)
    write_text(recording, text)
    if json_path is not None:
        write_json(json_path, doc)
    return doc
