"""``pnmold track``: photographs or one video of a bending actuator to a recording."""

from __future__ import annotations

from rich.markup import escape

from pnmold.cli._common import emit_json, err_console, json_file, out_console, stages
from pnmold.conventions import ORIENTATIONS
from pnmold.errors import UsageError

HELP = "photographs or a video of a bending actuator to a recording (bend angle, tip)"
DESCRIPTION = ("Track a bending actuator through photographs (in order) or one video: the first frame shows it at "
               "rest, --base and --tip are the pixels (x from the left, y from the top) of the middle of its "
               "clamped end, where it leaves the clamp, and of its free end on that frame. pnmold learns the body's "
               "look from the first frame, traces it in every frame and measures the bend angle and the tip in "
               "pnmold's frame (mm), at a scale given, found on a grid behind the actuator, or from the free "
               "length. Writes a recording (`pnmold docs recording-format`) ready for `pnmold diagnose`, with "
               "each frame's confidence; skipped frames are named with their reason. See `pnmold docs track`.")


def _point(text: str, name: str) -> tuple[float, float]:
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return float(parts[0]), float(parts[1])
    except ValueError:
        raise UsageError(f"--{name}: {text!r} is not X,Y in pixels (e.g. 266,335)") from None


def add_args(parser) -> None:
    parser.add_argument("frames", nargs="+", metavar="FRAMES",
                        help="image files in order (PNG, JPEG, TIFF, ...) or one video (mp4, avi, mov, ...)")
    where = parser.add_argument_group("the body on the first frame (at rest)")
    where.add_argument("--base", required=True, metavar="X,Y", help="middle of the clamped end, where it leaves "
                       "the clamp (px)")
    where.add_argument("--tip", required=True, metavar="X,Y", help="middle of the free end (px)")
    load = parser.add_argument_group("pressures (one of)")
    load.add_argument("--pressures-kpa", metavar="P1,P2,...", help="one pressure per frame tracked, kPa")
    load.add_argument("--pressure-log", metavar="LOG.csv", help="a logger's CSV: time_s and a pressure column "
                      "(pressure_kpa, pressure_psi, ...; supply_<unit> for --kind step), matched to frame times")
    load.add_argument("--fps", type=float, metavar="F", help="frames per second (default: the video's own rate)")
    load.add_argument("--offset-s", type=float, default=0.0, metavar="S",
                      help="the log's time at the first frame (default 0)")
    load.add_argument("--every", type=int, default=1, metavar="N", help="track every N-th frame (default 1)")
    scale = parser.add_argument_group("scale (one of; default the design's free length)")
    scale.add_argument("--scale-mm-per-px", type=float, metavar="S", help="millimetres per pixel")
    scale.add_argument("--grid-mm", type=float, metavar="G", help="a grid of G mm squares behind the actuator, "
                       "found and measured in the first frame")
    scale.add_argument("--free-length-mm", type=float, metavar="L", help="the free length (base to tip at rest)")
    out = parser.add_argument_group("design and outputs")
    out.add_argument("--design", metavar="D", help="template name or TOML file: its free length for the scale, "
                     "its clamp for x, its name in the recording")
    out.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                     help="override a field of --design (repeatable)")
    out.add_argument("--orientation", choices=list(ORIENTATIONS), help="where gravity pointed, for the "
                     "recording's metadata (default: not stated, read as chambers_up)")
    out.add_argument("--kind", choices=["bending", "step"], default="bending",
                     help="recording kind (step: time, supply and pressure from --pressure-log)")
    out.add_argument("--recording", required=True, metavar="OUT.csv", help="the recording to write")
    out.add_argument("--overlay", metavar="DIR", help="write each frame with its trace drawn, and "
                     "contact_sheet.png, into DIR (a folder pnmold wrote, an empty or a new one)")
    out.add_argument("--json", metavar="FILE", help="write the summary (schema pnmold.track/1) as JSON; - for "
                     "standard output")


def run(args) -> int:
    from pnmold.fsutil import check_replaceable
    from pnmold.track import TrackOptions, parse_pressures, read_frames, read_pressure_log, track_frames, write_outputs

    base, tip = _point(args.base, "base"), _point(args.tip, "tip")
    if args.pressures_kpa is not None and args.pressure_log is not None:
        raise UsageError("--pressures-kpa and --pressure-log: give one")
    pressures = tuple(parse_pressures(args.pressures_kpa)) if args.pressures_kpa is not None else None
    log = read_pressure_log(args.pressure_log) if args.pressure_log is not None else None
    if args.set and args.design is None:
        raise UsageError("--set: give --design for it to override")
    design = None
    if args.design is not None:
        from pnmold.design import load_design

        design = load_design(args.design, args.set)
    free, free_source = args.free_length_mm, "given"
    chosen = [n for n, v in (("--scale-mm-per-px", args.scale_mm_per_px), ("--grid-mm", args.grid_mm),
                             ("--free-length-mm", args.free_length_mm)) if v is not None]
    if len(chosen) > 1:
        raise UsageError(f"{chosen[0]} and {chosen[1]}: give one way to the scale")
    if not chosen and design is not None:
        free, free_source = design.free_length_mm, f"of design {design.name}"
    if args.overlay:
        check_replaceable(args.overlay)  # refused before the work, not after it
    options = TrackOptions(base, tip, pressures, log, args.scale_mm_per_px, args.grid_mm, free, free_source,
                           design.clamp_end_mm if design is not None else 0.0, args.every, args.fps, args.offset_s)
    with stages(args, "track") as say:
        say("read the frames")
        frames, footage = read_frames(args.frames, args.every, args.fps)
        say(f"trace {len(frames)} frame(s)")
        tracking = track_frames(frames, footage, options)
        say("write the recording")
        doc = write_outputs(tracking, frames, args.recording, kind=args.kind,
                            design=design.name if design is not None else None, orientation=args.orientation,
                            json_path=json_file(args), overlay=args.overlay)
    emit_json(args, doc)
    _summary(args, tracking)
    return 0


def _summary(args, tracking) -> None:
    for f in tracking.frames:
        if not f.accepted:
            err_console.print(f"[yellow]skipped[/yellow] frame {f.index} ({escape(f.name)}): {escape(str(f.reason))}")
    if args.quiet:
        return
    out_console.print(f"scale: {tracking.scale.mm_per_px:.5g} mm/px ({escape(tracking.scale.words)}); bending length "
                      f"{tracking.bending_length_mm:.2f} mm")
    for f in tracking.accepted:
        out_console.print(f"frame {f.index}: {f.pressure_kpa:.4g} kPa, bend {f.bend_angle_deg:.1f} deg, tip "
                          f"({f.tip_x_mm:.1f}, {f.tip_z_mm:.1f}) mm, confidence {f.confidence:.2f}")
    out_console.print(f"wrote {escape(args.recording)} ({len(tracking.accepted)} of {len(tracking.frames)} frames)"
                      + (f" and {escape(args.overlay)}/" if args.overlay else ""))
