"""``pnmold simulate DESIGN --dynamic``: the step response on the command line.

Parses the dynamic options into a :class:`~pnmold.pneumatics.network.Rig`, gets the
design's chamber law (the FE's free-bending curve), runs :func:`simulate_step`, and writes
the JSON (schema ``pnmold.simulation/1``, ``model: dynamic``), the ``step`` recording
(CONTRACTS.md §4) and the figure. Bad options exit 2 naming the option.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from pnmold.errors import UsageError
from pnmold.pneumatics.dynamics import OUTPUT_STEP_S, StepResponse, simulate_step
from pnmold.pneumatics.effects import check_effects, with_effects
from pnmold.pneumatics.gas import Orifice
from pnmold.pneumatics.network import (
    TUBING_LENGTH_MM,
    VALVE_CRITICAL_RATIO,
    VALVE_ORIFICE_MM,
    ActuatorLine,
    Rig,
)

MAX_SUPPLY_KPA = 1000.0
MAX_DURATION_S = 60.0
STEP_COLUMNS = ("time_s", "supply_kpa", "pressure_kpa", "flow_slpm", "bend_angle_deg", "tip_x_mm", "tip_z_mm")


def _positive(option: str, value: float | None, hi: float = math.inf) -> None:
    if value is not None and not (math.isfinite(value) and 0 < value <= hi):
        limit = f" and at most {hi:g}" if math.isfinite(hi) else ""
        raise UsageError(f"{option} must be a positive number{limit}, got {value:g}")


def rig_from_args(args, design) -> Rig:
    """The bench of the command line, with the dynamic effects; UsageError names the option."""
    if args.supply_kpa is None:
        raise UsageError("--supply-kpa is required with --dynamic (regulated supply, gauge kPa)")
    _positive("--supply-kpa", args.supply_kpa, MAX_SUPPLY_KPA)
    _positive("--valve-orifice-mm", args.valve_orifice_mm, 20.0)
    _positive("--valve-sonic-conductance", args.valve_sonic_conductance, 100.0)
    tubing_mm = args.tubing_length_mm if args.tubing_length_mm is not None else TUBING_LENGTH_MM
    _positive("--tubing-length-mm", tubing_mm, 100_000.0)
    _positive("--tubing-id-mm", args.tubing_id_mm, 50.0)
    _positive("--duration-s", args.duration_s, MAX_DURATION_S)
    _positive("--vent-at-s", args.vent_at_s, MAX_DURATION_S)
    if args.valve_orifice_mm is not None and args.valve_sonic_conductance is not None:
        raise UsageError("--valve-orifice-mm and --valve-sonic-conductance: give one of them, not both")
    b = args.valve_critical_ratio if args.valve_critical_ratio is not None else VALVE_CRITICAL_RATIO
    if not (math.isfinite(b) and 0 <= b < 0.999):
        raise UsageError(f"--valve-critical-ratio must be in [0, 0.999), got {b:g}")
    if args.valve_sonic_conductance is not None:
        valve = Orifice.from_l_per_s_bar(args.valve_sonic_conductance, b)
    else:
        valve = Orifice.from_diameter_mm(args.valve_orifice_mm or VALVE_ORIFICE_MM, b)
    vent = None
    if args.vent_at_s is not None:
        vent = round(args.vent_at_s / OUTPUT_STEP_S) * OUTPUT_STEP_S
        if vent < OUTPUT_STEP_S:
            raise UsageError(f"--vent-at-s must be at least {OUTPUT_STEP_S:g} s, got {args.vent_at_s:g}")
    rig = Rig(args.supply_kpa, valve, valve, tubing_mm,
              args.tubing_id_mm if args.tubing_id_mm is not None else design.inlet.tubing_id_mm, vent_at_s=vent)
    return with_effects(rig, _effects(args.effects))


def _effects(text: str | None) -> dict[str, float]:
    from pnmold.simulate import parse_effects

    try:
        return check_effects(dict(parse_effects(text)))
    except ValueError as err:
        raise UsageError(f"--effects: {err}") from None


def simulation_doc(design, rig: Rig, response: StepResponse, effects: dict[str, float]) -> dict[str, Any]:
    """The ``pnmold.simulation/1`` document of a step response."""
    from pnmold.design import digest
    from pnmold.simulate import SCHEMA

    s = response.series
    series = {k: [round(float(v), 6) for v in s[k]] for k in s}
    step_keys = ("time_s", "supply_kpa", "pressure_kpa", "flow_slpm", "bend_angle_deg", "tip_x_mm", "tip_z_mm",
                 "cavity_volume_ml")
    steps = [{k: series[k][i] for k in step_keys} for i in range(len(series["time_s"]))]
    info = {k: (round(v, 9) if isinstance(v, float) else v) for k, v in response.info.items()}
    return {
        "schema": SCHEMA, "design": {"name": design.name, "digest": digest(design)}, "model": "dynamic",
        "kind": "step", "effects": effects,
        "inputs": {"supply_kpa": rig.supply_kpa, "tubing_length_mm": rig.tubing_length_mm,
                   "tubing_id_mm": rig.tubing_id_mm, "valve_sonic_conductance_l_per_s_bar":
                   round(rig.supply_valve.conductance_l_per_s_bar, 6),
                   "valve_critical_ratio": rig.supply_valve.critical_ratio, "valve_volume_ml": rig.valve_volume_ml,
                   "vent_at_s": rig.vent_at_s, "dead_volume_ml": rig.dead_volume_ml,
                   "flow_restriction": rig.flow_restriction, "atmosphere_kpa": rig.atmosphere_kpa,
                   "temperature_k": rig.temperature_k},
        "time_to_full_bend_s": None if response.time_to_full_bend_s is None
        else round(response.time_to_full_bend_s, 9),
        "reason": response.reason,
        "full_bend_pressure_kpa": round(response.info["full_bend_pressure_kpa"], 6),
        "model_info": info,
        "series": series,
        "chamber_pressure_kpa": np.round(response.chamber_pressure_kpa, 6).tolist(),
        "steps": steps,
    }


def _plot_path(args, design) -> Path:
    if args.plot:
        return Path(args.plot)
    for given in (args.json, args.recording):
        if given:
            return Path(given).with_suffix(".png")
    from pnmold.pipeline import default_out_dir

    return Path(default_out_dir(design)) / "step_response.png"


def cmd_simulate_dynamic(args) -> int:
    """The ``--dynamic`` branch of ``pnmold simulate``."""
    from rich.markup import escape

    from pnmold.cli import err_console, out_console
    from pnmold.design import load_design
    from pnmold.fsutil import write_json
    from pnmold.pneumatics.law import chamber_law_for
    from pnmold.pneumatics.mechanics import BendingDynamics
    from pnmold.pneumatics.plot import plot_step
    from pnmold.recording import write_recording

    design = load_design(args.design, args.set)
    rig = rig_from_args(args, design)
    effects = _effects(args.effects)
    say = (lambda msg: None) if args.quiet else (lambda msg: err_console.print(f"[dim]…[/dim] {escape(msg)}"))
    say(f"{design.name}: chamber law (FE free-bending curve)")
    law = chamber_law_for(design, progress=say)
    say(f"step response: {args.duration_s:g} s at {rig.supply_kpa:g} kPa ({args.gas_law})")
    response = simulate_step(law, ActuatorLine.from_design(design), BendingDynamics.from_design(design), rig,
                             duration_s=args.duration_s, gas_law=args.gas_law)
    doc = simulation_doc(design, rig, response, effects)
    written = []
    if args.json:
        written.append(write_json(args.json, doc))
    if args.recording:
        meta = {"design": design.name, "orientation": "horizontal", "model": "dynamic",
                "supply_kpa": f"{rig.supply_kpa:g}", "tubing_length_mm": f"{rig.tubing_length_mm:g}",
                "tubing_id_mm": f"{rig.tubing_id_mm:g}", "gas_law": args.gas_law}
        if effects:
            meta["effects"] = ",".join(f"{k}={v:g}" for k, v in effects.items())
        written.append(write_recording(args.recording, "step", response.recording_columns(), meta))
    written.append(plot_step(response, _title(design, rig, response), _plot_path(args, design)))
    if not args.quiet:
        _summary(out_console, response, rig)
        out_console.print("wrote " + ", ".join(str(p) for p in written))
    return 0


def _title(design, rig: Rig, response: StepResponse) -> str:
    tfb = response.time_to_full_bend_s
    head = f"{design.name}: {rig.supply_kpa:g} kPa supply, tubing {rig.tubing_length_mm:g} mm x {rig.tubing_id_mm:g} mm"
    return head + (f"; full bend at {tfb * 1000:.1f} ms" if tfb is not None else f"; {response.reason}")


def _summary(console, response: StepResponse, rig: Rig) -> None:
    s, info = response.series, response.info
    tfb = response.time_to_full_bend_s
    console.print(f"time to full bend: {tfb * 1000:.1f} ms" if tfb is not None
                  else f"time to full bend: never ({response.reason})")
    console.print(f"peak flow {np.max(s['flow_slpm']):.2f} SLPM; at {s['time_s'][-1]:g} s: inlet "
                  f"{s['pressure_kpa'][-1]:.1f} kPa, far chamber {s['pressure_far_kpa'][-1]:.1f} kPa, "
                  f"volume change {s['volume_ml'][-1]:.2f} mL, bend {s['bend_angle_deg'][-1]:.0f} deg")
    console.print(f"quasi-static full bend at {info['full_bend_pressure_kpa']:.1f} kPa "
                  f"({info['volume_change_at_full_bend_ml']:.2f} mL); bending mode "
                  f"{info['natural_frequency_hz']:.1f} Hz, damping ratio {info['damping_ratio']:g} (assumed)")
