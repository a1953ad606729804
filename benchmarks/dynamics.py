"""Rapid actuation: fPN against sPN at the same supply, and the fPN at 345 kPa
beside the paper's ~50 ms.

1. fPN vs sPN at one supply: the time to full bend and the volume change each needs
   (quasi-static, from the FE law); both ratios (sPN / fPN) are printed. Where an FE curve
   stops short of full bend (the sPN's ends at its pressure maximum) no full-bend figure is
   given: no law is read past the FE's last solved step (issue 43); the same ratios at the
   largest angle both FE curves reach are printed, and the step model ends where a chamber
   reaches the law's last pressure (the reason says so).
2. The fPN's time to full bend at 345 kPa supply beside the paper's: Mosadegh et al.,
   Adv. Funct. Mater. 24 (2014) 2109, abstract: an fPN "can bend fully in ~50 ms" when
   pressurised at 345 kPa (50 psi). (The supplement's "Characterizing the Rapid Actuation of
   fPNs" describes only the rig: regulator, two solenoid valves, flow and pressure sensors.)
   Then what sets the time: the mean pressure drop over the fill across each restriction
   (valve, tubing, channel), and the time with each restriction or the bending inertia taken
   away in turn, plus the tubing-length sweep.

Needs the FE characterisation of both templates (``pnmold.physics.characterise``, cached
in ``out/.cache/fe``; a few minutes each the first time).

    .venv/bin/python benchmarks/dynamics.py [--supply-kpa 345] [--duration-s 0.8]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pnmold.design import load_design  # noqa: E402
from pnmold.pneumatics import ActuatorLine, BendingDynamics, Orifice, Rig, chamber_law_for, simulate_step  # noqa: E402
from pnmold.pneumatics.gas import slpm_from_kg_s  # noqa: E402

PAPER_MS = 50.0  # Mosadegh et al. 2014, abstract: full bend in ~50 ms at 345 kPa


def _run(design, law, rig, duration_s, *, line=None, bending=None):
    line = line or ActuatorLine.from_design(design)
    bending = bending or BendingDynamics.from_design(design)
    t0 = time.perf_counter()
    res = simulate_step(law, line, bending, rig, duration_s=duration_s)
    return res, time.perf_counter() - t0


def _ms(t):
    return f"{t * 1000:7.1f} ms" if t is not None else "  never  "


def _at(res, key, t):
    return float(np.interp(t, res["time_s"], res[key]))


def _mean_pressure_time(res, p_kpa):
    """First time the mean chamber pressure reaches ``p_kpa`` (None if never)."""
    mean = res.chamber_pressure_kpa.mean(axis=1)
    i = np.flatnonzero(mean >= p_kpa)
    if not len(i):
        return None
    i = i[0]
    if i == 0:
        return 0.0
    t = res["time_s"]
    return float(t[i - 1] + (p_kpa - mean[i - 1]) / (mean[i] - mean[i - 1]) * (t[i] - t[i - 1]))


def _time_to_angle(res, angle_deg):
    a, t = res["bend_angle_deg"], res["time_s"]
    i = np.flatnonzero(a >= angle_deg)
    if not len(i) or i[0] == 0:
        return None
    i = i[0]
    return float(t[i - 1] + (angle_deg - a[i - 1]) / (a[i] - a[i - 1]) * (t[i] - t[i - 1]))


def compare(laws, designs, supply_kpa, duration_s):
    print(f"\n== fPN vs sPN at {supply_kpa:g} kPa supply (default bench: 1.0 mm valves, "
          f"300 mm x 0.79 mm tubing, isothermal) ==")
    common = 5.0 * np.floor(min(law.angle_deg_samples[-1] for law in laws.values()) / 5.0)
    rows = {}
    for name in ("fpn", "spn"):
        design, law = designs[name], laws[name]
        res, wall = _run(design, law, Rig(supply_kpa), duration_s)
        info = res.info
        tfb = res.time_to_full_bend_s
        p_c = float(law.pressure_for_angle_kpa(common))
        dv_c = float(law.volume_ml(p_c) - law.volume_ml(0.0))
        rows[name] = {"tfb": tfb, "dv_fb": info["volume_change_at_full_bend_ml"], "t_c": _time_to_angle(res, common),
                      "dv_c": dv_c}
        quasi = (f"quasi-static at {info['full_bend_pressure_kpa']:.1f} kPa, volume change "
                 f"{info['volume_change_at_full_bend_ml']:.2f} mL" if info["full_bend_pressure_kpa"] is not None
                 else f"quasi-static: {law.short_of_full_bend()}")
        print(f"{name}: full bend {_ms(tfb)} ({quasi}); {common:.0f} deg at "
              f"{_ms(rows[name]['t_c']).strip()} (quasi-static {p_c:.1f} kPa, {dv_c:.2f} mL); rest volume "
              f"{float(law.volume_ml(0)):.2f} mL; mass {info['mass_g']:.1f} g, bending mode "
              f"{info['natural_frequency_hz']:.1f} Hz [{wall * 1000:.0f} ms, {info['steps']} steps]")
        if tfb is None:
            print(f"     {res.reason}")
    f, s_ = rows["fpn"], rows["spn"]
    if f["t_c"] and s_["t_c"]:
        print(f"ratio sPN / fPN, time to {common:.0f} deg (inside both FE curves): {s_['t_c'] / f['t_c']:.2f}")
    print(f"ratio sPN / fPN, volume change to {common:.0f} deg: {s_['dv_c'] / f['dv_c']:.2f}")
    if f["tfb"] and s_["tfb"]:
        print(f"ratio sPN / fPN, time to full bend: {s_['tfb'] / f['tfb']:.2f}")
    if f["dv_fb"] is not None and s_["dv_fb"] is not None:
        print(f"ratio sPN / fPN, volume change to full bend: {s_['dv_fb'] / f['dv_fb']:.2f}")
    return rows


def explain_fpn(design, law, supply_kpa, duration_s):
    print(f"\n== fPN at {supply_kpa:g} kPa supply against the paper ==")
    base, _ = _run(design, law, Rig(supply_kpa), duration_s)
    tfb = base.time_to_full_bend_s
    if tfb is None:
        print(f"fPN never reaches full bend: {base.reason}")
        return
    print(f"time to full bend: model {tfb * 1000:.1f} ms, paper ~{PAPER_MS:.0f} ms "
          f"(Mosadegh et al. 2014, abstract); model / paper = {tfb * 1000 / PAPER_MS:.2f}")
    p_fb = base.info["full_bend_pressure_kpa"]
    t_p = _mean_pressure_time(base, p_fb)
    mode = (f"{base.info['natural_frequency_hz']:.1f} Hz bending mode (quarter period "
            f"{250 / base.info['natural_frequency_hz']:.0f} ms), damping ratio {base.info['damping_ratio']:g} assumed")
    if t_p is None:
        print(f"the mean chamber pressure never reaches the quasi-static full-bend pressure ({p_fb:.1f} kPa) "
              f"before the bend does: the {mode} overshoots")
    elif t_p <= tfb:
        print(f"the mean chamber pressure reaches the quasi-static full-bend pressure ({p_fb:.1f} kPa) at "
              f"{t_p * 1000:.1f} ms; the bend lags it by {1000 * (tfb - t_p):.1f} ms ({mode})")
    else:
        print(f"the bend reaches 360 degrees {1000 * (t_p - tfb):.1f} ms before the mean chamber pressure reaches "
              f"the quasi-static full-bend pressure ({p_fb:.1f} kPa, at {t_p * 1000:.1f} ms): the {mode} overshoots "
              "its slowly rising quasi-static angle")
    s = base.series
    fill = s["time_s"] <= tfb
    t = s["time_s"][fill]

    def mean_drop(upper, lower):
        return float(np.trapezoid(upper[fill] - lower[fill], t) / t[-1])

    drops = {"supply valve": mean_drop(s["supply_kpa"], s["pressure_valve_kpa"]),
             "tubing (300 mm x 0.79 mm)": mean_drop(s["pressure_valve_kpa"], s["pressure_kpa"]),
             "inlet and channel to the far chamber": mean_drop(s["pressure_kpa"], s["pressure_far_kpa"])}
    print("mean pressure drop over the fill (0 to full bend):")
    for k, v in drops.items():
        print(f"  {k:<40} {v:7.1f} kPa")
    gas = _at(base, "metered_std_ml", tfb)
    bore = Orifice.from_diameter_mm(design.inlet.tubing_id_mm, 0.528)  # an ideal nozzle of the tubing's bore
    choke = float(slpm_from_kg_s(bore.mass_flow_kg_s((supply_kpa + 101.325) * 1000, 0.0)))
    print(f"peak flow {np.max(s['flow_slpm']):.1f} SLPM, mean {gas / tfb * 60 / 1000:.1f} SLPM; gas metered to full "
          f"bend {gas:.1f} std mL")
    print(f"flow floor: the {design.inlet.tubing_id_mm:.3g} mm bore choked at {supply_kpa:g} kPa passes at most "
          f"{choke:.1f} SLPM, so {gas:.1f} std mL take at least {gas / choke * 60:.0f} ms however short the tubing")

    line = ActuatorLine.from_design(design)
    bend = BendingDynamics.from_design(design)
    wide = dataclasses.replace(line, channel_height_mm=4.0, channel_width_mm=4.0)
    cases = [
        ("valves 5 mm (valve restriction away)", Rig(supply_kpa, Orifice.from_diameter_mm(5.0),
                                                     Orifice.from_diameter_mm(5.0)), line, bend),
        ("tubing 20 mm long", Rig(supply_kpa, tubing_length_mm=20.0), line, bend),
        ("tubing 1.6 mm bore (1/16 in)", Rig(supply_kpa, tubing_id_mm=1.5875), line, bend),
        ("channel 4 x 4 mm (channel restriction away)", Rig(supply_kpa), wide, bend),
        ("no bending inertia (mass / 1e4)", Rig(supply_kpa), line,
         dataclasses.replace(bend, mass_kg=bend.mass_kg * 1e-4)),
        ("tubing 20 mm, no bending inertia", Rig(supply_kpa, tubing_length_mm=20.0), line,
         dataclasses.replace(bend, mass_kg=bend.mass_kg * 1e-4)),
    ]
    print("time to full bend with one limit taken away:")
    for label, rig, ln, bd in cases:
        res, _ = _run(design, law, rig, duration_s, line=ln, bending=bd)
        print(f"  {label:<45} {_ms(res.time_to_full_bend_s)}")
    print("tubing length sweep (0.79 mm bore):")
    for length in (50.0, 100.0, 300.0, 1000.0):
        res, _ = _run(design, law, Rig(supply_kpa, tubing_length_mm=length), duration_s)
        print(f"  {length:6.0f} mm  {_ms(res.time_to_full_bend_s)}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--supply-kpa", type=float, default=345.0)
    parser.add_argument("--duration-s", type=float, default=0.8)
    args = parser.parse_args(argv)
    designs = {n: load_design(n) for n in ("fpn", "spn")}
    laws = {}
    for n, d in designs.items():
        t0 = time.perf_counter()
        laws[n] = chamber_law_for(d, progress=lambda msg: print(f"... {msg}", flush=True))
        print(f"{n}: chamber law from the FE, {len(laws[n].pressure_kpa)} steps to "
              f"{laws[n].pressure_kpa[-1]:.1f} kPa ({laws[n].angle_deg_samples[-1]:.0f} deg) "
              f"[{time.perf_counter() - t0:.1f} s]", flush=True)
    compare(laws, designs, args.supply_kpa, max(args.duration_s, 3.0))
    explain_fpn(designs["fpn"], laws["fpn"], args.supply_kpa, args.duration_s)
    return 0


if __name__ == "__main__":
    sys.exit(main())
