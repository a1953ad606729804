"""``pnmold simulate``: a quasi-static curve (FE or reduced model), or with ``--dynamic`` the
step response; as JSON and/or a recording in the lab format (synthetic data)."""

from __future__ import annotations

from rich.markup import escape

from pnmold.cli._common import add_design, emit_json, err_console, json_file, load, out_console, stages
from pnmold.conventions import ORIENTATIONS, QUASI_STATIC_KINDS

#: most rows printed to the console (half from each end; a logger's worth of rows goes to the files)
PRINTED_ROWS = 200

HELP = "quasi-static response (FE or reduced model) or step response, as JSON or a recording"
DESCRIPTION = ("Solve the design's pressure curve with the FE model or the reduced model (--model rom, "
               "characterised by the FE once: templates ship theirs, others are cached): free bending, "
               "pressure-volume, or blocked tip force, with physics effects switched on; or with --dynamic the "
               "time response to a supply step. Write it as JSON (pnmold.simulation/1: `pnmold docs json-schemas`) "
               "and/or as a recording in the lab format (synthetic data: `pnmold docs recording-format`).")


def add_args(parser) -> None:
    add_design(parser)
    curve = parser.add_argument_group("quasi-static curve")
    curve.add_argument("--pressures", default="0:40:5", metavar="A:B:STEP", help="kPa (default 0:40:5)")
    curve.add_argument("--model", choices=["fe", "rom"], default="fe")
    curve.add_argument("--kind", choices=list(QUASI_STATIC_KINDS), default="bending")
    curve.add_argument("--cycles", type=int, default=1, help="inflate and deflate N times")
    curve.add_argument("--rate-kpa-per-s", type=float, default=None,
                       help="ramp rate: the rows' time_s (viscoelasticity needs it); recorded as metadata")
    curve.add_argument("--orientation", choices=list(ORIENTATIONS), default="chambers_up",
                       help="where gravity points (default chambers_up)")
    both = parser.add_argument_group("effects and outputs")
    both.add_argument("--effects", metavar="NAME=VALUE,...",
                      help="physics effects and NAME.PARAM=VALUE (see `pnmold effects`; FE: gravity, "
                      "strain_stiffening, layer_compliance; --dynamic: dead_volume, flow_restriction)")
    both.add_argument("--self-contact", action="store_true",
                      help="--model fe: keep the walls from passing through each other (about twice the time)")
    both.add_argument("--vtu", metavar="DIR",
                      help="--model fe: write every converged step as DIR/step_NNN.vtu with DIR/bending.pvd "
                      "(force.pvd for --kind force) for ParaView")
    both.add_argument("--recording", metavar="FILE.csv",
                      help="write the result in the recording format (`pnmold docs recording-format`)")
    both.add_argument("--json", metavar="FILE",
                      help="write pnmold.simulation/1 JSON (`pnmold docs json-schemas`); - for standard output")
    noise = parser.add_argument_group("synthetic noise of --recording")
    noise.add_argument("--noise-mm", type=float, default=0.0, metavar="SIGMA",
                       help="Gaussian noise on tip_x_mm and tip_z_mm (standard deviation, mm)")
    noise.add_argument("--noise-ml", type=float, default=0.0, metavar="SIGMA", help="noise on volume_ml (mL)")
    noise.add_argument("--noise-n", type=float, default=0.0, metavar="SIGMA", help="noise on force_n (N)")
    noise.add_argument("--seed", type=int, default=None, help="seed of the recording's noise")
    dyn = parser.add_argument_group("step response (--dynamic)")
    dyn.add_argument("--dynamic", action="store_true", help="time response to a supply step (valve opens at t = 0)")
    dyn.add_argument("--supply-kpa", type=float, metavar="P", help="regulated supply, gauge kPa (required)")
    dyn.add_argument("--valve-orifice-mm", type=float, metavar="D",
                     help="effective orifice of the supply and vent valves (default 1.0, assumed)")
    dyn.add_argument("--valve-sonic-conductance", type=float, metavar="C",
                     help="the valves' ISO 6358 sonic conductance in dm3/(s bar), instead of the orifice")
    dyn.add_argument("--valve-critical-ratio", type=float, metavar="B",
                     help="the valves' ISO 6358 critical pressure ratio (default 0.5)")
    dyn.add_argument("--tubing-length-mm", type=float, help="tubing from valves to actuator (default 300)")
    dyn.add_argument("--tubing-id-mm", type=float,
                     help="tubing bore (default the design's inlet.tubing_id_mm, 1/32 in = 0.79375 mm)")
    dyn.add_argument("--vent-at-s", type=float, metavar="T", help="close supply, open vent at T s")
    dyn.add_argument("--duration-s", type=float, default=0.5, help="simulated time (default 0.5 s)")
    dyn.add_argument("--gas-law", choices=["isothermal", "adiabatic"], default="isothermal",
                     help="gas in the chambers (isothermal; adiabatic is refused: the step model is isothermal)")
    dyn.add_argument("--plot", metavar="FILE.png", help="figure (default beside --json or --recording)")


def run(args) -> int:
    if args.dynamic:
        if args.self_contact:
            from pnmold.errors import UsageError

            raise UsageError("--self-contact: the quasi-static FE's (--model fe), not the step response's")
        return _run_dynamic(args)
    from pnmold.simulate import Noise, SimulationRequest, parse_effects, parse_pressures, simulate

    design = load(args)
    request = SimulationRequest(parse_pressures(args.pressures), args.model, args.kind, args.cycles,
                                args.orientation, parse_effects(args.effects), args.rate_kpa_per_s,
                                self_contact=args.self_contact)
    noise = Noise(args.noise_mm, args.noise_ml, args.noise_n, args.seed)
    with stages(args, f"characterise {design.name} (once)") as say:
        doc = simulate(design, request, json_path=json_file(args), recording_path=args.recording, noise=noise,
                       progress=say, vtu_dir=args.vtu).doc
    emit_json(args, doc)
    if not args.quiet:
        steps = doc["steps"]
        shown = steps if len(steps) <= PRINTED_ROWS else [*steps[:PRINTED_ROWS // 2], None,
                                                           *steps[-PRINTED_ROWS // 2:]]
        for s in shown:
            if s is None:
                out_console.print(f"   ... {len(steps) - PRINTED_ROWS} more rows (all {len(steps)} in the recording "
                                  f"or the JSON)")
                continue
            extra = f", force {s['force_n']:.3f} N" if "force_n" in s else ""
            out_console.print(f"{s['pressure_kpa']:8.2f} kPa: bend {s['bend_angle_deg']:7.1f} deg, tip "
                              f"({s['tip_x_mm']:.1f}, {s['tip_z_mm']:.1f}) mm, "
                              f"cavity {s['cavity_volume_ml']:.3f} mL{extra}")
        fb = doc["full_bend_pressure_kpa"]
        out_console.print(f"full bend: {fb:.1f} kPa" if fb is not None else f"full bend: not reached ({doc['reason']})")
    return 0


def _run_dynamic(args) -> int:
    from pnmold.simulate import parse_effects
    from pnmold.simulate.dynamic import dynamic_effects, rig_for, run_step_study

    design = load(args)
    effects = dynamic_effects(dict(parse_effects(args.effects)))
    rig = rig_for(design, supply_kpa=args.supply_kpa, valve_orifice_mm=args.valve_orifice_mm,
                  valve_sonic_conductance=args.valve_sonic_conductance,
                  valve_critical_ratio=args.valve_critical_ratio, tubing_length_mm=args.tubing_length_mm,
                  tubing_id_mm=args.tubing_id_mm, vent_at_s=args.vent_at_s, effects=effects)
    say = None if args.quiet else (lambda msg: err_console.print(f"[dim]…[/dim] {escape(msg)}"))
    study = run_step_study(design, rig, duration_s=args.duration_s, gas_law=args.gas_law, effects=effects,
                           json_path=json_file(args), recording_path=args.recording, plot_path=args.plot,
                           progress=say)
    emit_json(args, study.document)
    if not args.quiet:
        for line in study.summary:
            out_console.print(escape(line))
        out_console.print("wrote " + ", ".join(str(p) for p in study.written))
    return 0
