"""The body's roll held on its side (pnmold.physics.roll): closed forms, the identification's round trip,
the camera's view and the sections' rolls read from a rotated point cloud."""

from __future__ import annotations

import numpy as np
import pytest

from pnmold.design import load_design
from pnmold.physics.rod import RodLoads, moments, node_positions, solve_rod
from pnmold.physics.roll import identify_roll, lever, roll_axis_mm, rolled, section_rolls, world

K = 40
LENGTH = np.full((1, K), 150.0 / K)


def _straight_solve(compliance_hinge: float, loads: RodLoads, g: float):
    """solve(share, last) of a straight rod whose hinges have ``compliance_hinge`` (rad per N mm) under ``g``
    chambers down, each hinge feeling ``share`` of its moment (as :func:`rolled` asks)."""
    free, comp = np.zeros((1, K)), np.full((1, K), compliance_hinge)
    return lambda share, last=None: solve_rod(free, LENGTH, comp, loads, (0.0, g), share=share)


def test_a_uniform_rod_twists_as_the_distal_weight_turns_it():
    """Rigid in its plane, uniform weight w per mm at height h over the axis a, uniform torsional compliance c
    per mm, a light weight (cos phi ~ 1): phi(x) = c g w (h - a) (L x - x^2 / 2), the closed form of
    GJ phi' = T(x) = g w (h - a) (L - x); the discrete sums within 1/K of it."""
    w, h, a, c, g = 0.0015, 8.0, 2.0, 2e-3, 0.05
    dx = 150.0 / K
    loads = RodLoads(np.full(K, w * dx), np.full(K, 0.5), np.full(K, h))
    state = rolled(_straight_solve(0.0, loads, g), np.full((1, K), c * dx), loads, g, a)
    x = np.linspace(0.0, 150.0, K + 1)
    exact = c * g * w * (h - a) * (150.0 * x - x ** 2 / 2)
    assert state.roll_rad[0, -1] > 0.01
    assert np.allclose(state.roll_rad[0], exact, rtol=0.0, atol=1.5 / K * exact[-1])
    # the roll's weight in the plane: g sin(phi) toward +z, which opens the bend of a compliant rod
    bent = rolled(_straight_solve(1e-4, loads, g), np.full((1, K), c * dx), loads, g, a)
    assert bent.nodes_mm[0, -1, 1] > 0.0


def test_each_edge_twists_as_the_torque_turned_by_the_roll_along_it():
    """All the weight at the tip, the torsional compliance in the first two edges: along each the roll follows
    d phi / d tau = cos(phi), tau the compliance times the torque at no roll, k = W (h - a), integrated here
    independently (solve_ivp) over tau = c0 k, then c1 k; far from small."""
    from scipy.integrate import solve_ivp

    weight = np.zeros(K)
    weight[-1] = 0.2
    loads = RodLoads(weight, np.full(K, 0.5), np.full(K, 10.0))
    comp = np.zeros((1, K))
    comp[0, :2] = (0.4, 0.5)
    state = rolled(_straight_solve(0.0, loads, 1.0), comp, loads, 1.0, 2.0)
    k = 0.2 * 8.0
    ivp = solve_ivp(lambda tau, phi: np.cos(phi), (0.0, 0.9 * k), [0.0], t_eval=[0.4 * k, 0.9 * k], rtol=1e-11,
                    atol=1e-12)
    first, second = ivp.y[0]
    assert second > 1.0
    assert state.roll_rad[0, 1] == pytest.approx(first, abs=1e-8)
    assert state.roll_rad[0, 2:] == pytest.approx(np.full(K - 1, second), abs=1e-8)


def test_a_hinge_feels_its_share_of_the_weights_moment_and_all_of_the_tip_force():
    """The rod's hinge shares scale the weight's moment hinge by hinge, not the plane's force at the tip."""
    rng = np.random.default_rng(5)
    angle = rng.uniform(-0.5, 0.5, (2, K))
    nodes = node_positions(angle, LENGTH)
    loads = RodLoads(rng.uniform(0.001, 0.01, K), np.full(K, 0.5), np.full(K, 6.0))
    share = rng.uniform(0.0, 1.0, (2, K))
    weight, _ = moments(nodes, angle, loads, (0.0, 1.0), np.zeros(2))
    force, _ = moments(nodes, angle, loads, (0.0, 0.0), np.array([0.3, -0.2]))
    both, _ = moments(nodes, angle, loads, (0.0, 1.0), np.array([0.3, -0.2]), share)
    assert both == pytest.approx(share * weight + force, rel=1e-12, abs=1e-12)


def test_the_identification_returns_the_compliance_that_made_the_roll():
    """A roll made by :func:`rolled` with a known compliance, read back by :func:`identify_roll`."""
    design = load_design("fpn")
    loads = RodLoads(np.full(K, 0.005), np.full(K, 0.5), np.full(K, 9.0))
    truth = np.where(np.arange(K) % 4 == 1, 0.04, 0.002)[None, :]
    solve = _straight_solve(2e-4, loads, 1.0)
    made = rolled(solve, truth, loads, 1.0, roll_axis_mm(design))
    found = identify_roll(design, loads, made.roll_rad[0], lambda share: solve(share), 1.0)
    t = lever(made.nodes_mm, made.angle_rad, loads, roll_axis_mm(design))[0]
    counted = t > 0.1 * t.max()
    assert counted.sum() > K // 2
    assert found[counted] == pytest.approx(truth[0, counted], rel=1e-6)


def test_the_camera_sees_the_bending_plane_turned_by_the_roll():
    """Unrolled: the nodes as they are. Rolled 90 deg: the bending plane's z is seen edge on (0) and a bend
    of 60 deg is seen as 0; rolled 60 deg it is seen as atan(tan 60 cos 60)."""
    angle = np.full((1, K), np.radians(60.0))
    nodes = np.concatenate([np.zeros((1, 1, 2)), np.cumsum(np.stack(
        [np.cos(angle), -np.sin(angle)], axis=-1) * 150.0 / K, axis=1)], axis=1)
    same, end = world(nodes, angle[:, -1], np.zeros((1, K + 1)))
    assert np.allclose(same, nodes) and end == pytest.approx(angle[:, -1])
    flat, end = world(nodes, angle[:, -1], np.full((1, K + 1), np.pi / 2))
    assert np.allclose(flat[..., 1], 0.0, atol=1e-9) and end == pytest.approx([0.0], abs=1e-9)
    _, end = world(nodes, angle[:, -1] + 2 * np.pi, np.full((1, K + 1), np.pi / 3))
    assert end == pytest.approx([2 * np.pi + np.arctan(np.tan(np.pi / 3) * 0.5)])


def test_the_sections_rolls_are_read_from_a_rotated_point_cloud():
    """Sections of a box rotated about +x by a known angle each (positive: +z toward -y)."""
    rng = np.random.default_rng(3)
    pts = rng.uniform([0.0, -7.0, 0.0], [100.0, 7.0, 18.0], (20000, 3))
    x = np.linspace(0.0, 100.0, 11)
    phi = np.radians(np.interp(pts[:, 0], x, np.linspace(0.0, 30.0, 11)))
    y, z = pts[:, 1] - 0.0, pts[:, 2] - 3.0
    moved = np.column_stack([pts[:, 0], y * np.cos(phi) - z * np.sin(phi), y * np.sin(phi) + z * np.cos(phi) + 3.0])
    got = np.degrees(section_rolls(pts, moved - pts, x))
    assert got[0] == 0.0
    assert got == pytest.approx(np.linspace(0.0, 30.0, 11), abs=0.3)


def test_a_very_compliant_body_rolls_toward_a_quarter_turn_not_past_it():
    """The weight's torque vanishes as the chambers reach the ground (cos(roll)): however compliant, the
    roll climbs toward 90 deg and never passes it."""
    loads = RodLoads(np.full(K, 0.005), np.full(K, 0.5), np.full(K, 9.0))
    state = rolled(_straight_solve(0.0, loads, 1.0), np.full((1, K), 50.0), loads, 1.0, 2.0)
    roll = np.degrees(state.roll_rad[0])
    assert np.all(np.diff(roll) >= 0) and roll[-1] > 85.0
    assert roll.max() <= 90.0


def test_rows_without_an_equilibrium_come_back_nan_and_the_rest_solved():
    """A row the rod solver left NaN (``partial``: no equilibrium there) stays NaN, roll included."""
    import dataclasses

    loads = RodLoads(np.full(K, 0.005), np.full(K, 0.5), np.full(K, 9.0))
    free, length = np.zeros((3, K)), np.repeat(LENGTH, 3, axis=0)
    comp = np.full((3, K), 2e-4)

    def solve(share, last=None):
        state = solve_rod(free, length, comp, loads, (0.0, 1.0), share=share)
        lost = {}
        for key in ("angle_rad", "nodes_mm", "moment_n_mm"):
            lost[key] = getattr(state, key).copy()
            lost[key][1] = np.nan
        return dataclasses.replace(state, **lost)

    state = rolled(solve, np.full((3, K), 0.01), loads, 1.0, 2.0, partial=True)
    assert np.isnan(state.roll_rad[1]).all() and np.isnan(state.nodes_mm[1]).all()
    assert np.isfinite(state.roll_rad[[0, 2]]).all() and state.roll_rad[0, -1] > 0.05


def test_held_on_its_side_the_fpn_follows_the_fe_with_its_roll():
    """The FE of the whole fPN held horizontal (stored, ``benchmarks/rom_roll.py``) against the reduced model
    with its roll probe (at rest; every pressure above 0 kPa is a prediction) and without it (the weight out
    of the plane doing nothing): with the roll within 5 % of the length at every step, the rest tip within
    1.5 mm; without it over twice as far."""
    import dataclasses
    import json
    from pathlib import Path

    from pnmold.physics import Protocol, ReducedModel

    data = json.loads((Path(__file__).parent / "data" / "fpn-horizontal-steps.json").read_text())
    design = load_design(data["design"])
    rom = ReducedModel.for_design(design)
    c = rom.characterisation
    assert c.roll_compliance_rad_per_n_mm is not None and c.probe_roll["node_roll_deg"][-1] > 5.0
    flat = ReducedModel.for_design(design, dataclasses.replace(c, roll_compliance_rad_per_n_mm=None))
    steps = data["steps"]["horizontal"]
    p = np.array([s["pressure_kpa"] for s in steps])
    fe = np.array([[s["tip_x_mm"], s["tip_z_mm"]] for s in steps])

    def miss(model) -> np.ndarray:
        out = model.run(Protocol("bending", p, "horizontal"))
        return np.hypot(out["tip_x_mm"] - fe[:, 0], out["tip_z_mm"] - fe[:, 1])

    rolled_miss, flat_miss = miss(rom), miss(flat)
    assert p.size >= 4 and fe[0, 1] > 5.0  # the FE's rest tip is off toward the chambers
    assert rolled_miss.max() < 0.05 * design.length_mm and rolled_miss[0] < 1.5
    assert flat_miss.max() > 2 * rolled_miss.max()


def test_the_compliance_stiffens_with_the_effective_pressure():
    """The compliance over the table's factor at each row's pressure: 1 at rest, linear between the states
    read, held beyond the last (never extrapolated), the pressure floored at 0; no table leaves it."""
    from pnmold.physics.roll import stiffened

    c = np.array([0.01, 0.02, 0.0])
    table = {"pressure_kpa": [10.0, 20.0], "factor": [1.5, 3.0]}
    got = stiffened(c, np.array([0.0, 5.0, 10.0, 15.0, 40.0, -3.0]), table)
    assert got.shape == (6, 3)
    assert got[0] == pytest.approx(c) and got[5] == pytest.approx(c)
    assert got[1] == pytest.approx(c / 1.25) and got[2] == pytest.approx(c / 1.5)
    assert got[3] == pytest.approx(c / 2.25) and got[4] == pytest.approx(c / 3.0)
    assert stiffened(c, np.array([10.0]), None)[0] == pytest.approx(c)
    assert stiffened(c, np.array([10.0]), {"pressure_kpa": [], "factor": []})[0] == pytest.approx(c)


def test_the_stiffening_read_from_pressed_tips_is_the_one_that_made_them():
    """The fPN's roll probe with pressed states made by the reduced model itself at known factors, one
    stiffer and one softer than rest: the probe's reading gives them back, and without stiffening the
    model's tips there are millimetres off."""
    import dataclasses

    from pnmold.physics import Protocol, ReducedModel
    from pnmold.physics.probes import roll_stiffening

    design = load_design("fpn")
    c = ReducedModel.for_design(design).characterisation
    assert c.roll_compliance_rad_per_n_mm is not None
    p, truth = np.array([5.0, 10.0]), np.array([2.0, 0.7])
    protocol = Protocol("bending", p, "horizontal")
    made = ReducedModel(design, dataclasses.replace(c, roll_stiffening={"pressure_kpa": p.tolist(),
                                                                        "factor": truth.tolist()})).run(protocol)
    plain = ReducedModel(design, dataclasses.replace(c, roll_stiffening=None)).run(protocol)
    assert np.all(np.hypot(made["tip_x_mm"] - plain["tip_x_mm"], made["tip_z_mm"] - plain["tip_z_mm"]) > 1.0)
    pressed = [{"pressure_kpa": float(q), "tip_x_mm": float(x), "tip_z_mm": float(z)}
               for q, x, z in zip(p, made["tip_x_mm"], made["tip_z_mm"], strict=True)]
    probe = {**c.probe_roll, "pressed": pressed}
    found = roll_stiffening(design, dataclasses.replace(c, probe_roll=probe, roll_stiffening=None))
    assert found["pressure_kpa"] == pytest.approx(p)
    # the cost of a factor away from 1 (ROLL_STIFFENING_COST_SHARE) pulls it a little toward 1: within 10 %
    assert found["factor"] == pytest.approx(truth, rel=0.1)


def test_the_roll_probe_reads_only_the_pressures_it_asked_for_not_where_the_fe_stopped(tmp_path, monkeypatch):
    """The FE held on its side stopping short of the probe's range (a critical point between two asked
    pressures): its last state is kept aside with the reason, and the stiffening reads only the asked
    pressures it reached (FE stood in for by a run whose sections roll about +x by a known angle)."""
    import dataclasses
    from types import SimpleNamespace

    import pnmold.design_fe
    from pnmold.physics import probes
    from pnmold.physics.roll import ROLL_PROBE_SHARES

    design = load_design("fpn")
    monkeypatch.setenv("PNMOLD_CACHE", str(tmp_path))
    bundled = probes.downward_probe(design)
    start = dataclasses.replace(bundled, roll_stiffening=None, roll_compliance_rad_per_n_mm=None, probe_roll=None)
    monkeypatch.setattr(probes, "downward_probe", lambda *a, **k: start)
    asked = [s * float(start.pressure_kpa[-1]) for s in ROLL_PROBE_SHARES]
    reached = [0.0, *asked[:3], 0.5 * (asked[3] + asked[4])]  # stops between the 4th and 5th asked pressures
    nodes = np.array([[x, y, z] for x in np.linspace(0.0, design.length_mm, 200) for y in (-5.0, 5.0)
                      for z in (0.0, 10.0)])

    def rolled_by(deg: float) -> np.ndarray:  # the mesh's nodes turned about +x (positive sinks +z toward -y)
        a = np.radians(deg) * nodes[:, 0] / design.length_mm
        y = nodes[:, 1] * np.cos(a) - nodes[:, 2] * np.sin(a)
        z = nodes[:, 1] * np.sin(a) + nodes[:, 2] * np.cos(a)
        return np.stack([np.zeros_like(y), y - nodes[:, 1], z - nodes[:, 2]], axis=1)

    steps = [SimpleNamespace(pressure_kpa=p, tip_x_mm=110.0 - p, tip_z_mm=5.0 - 2.0 * p, bend_angle_deg=3.0 * p)
             for p in reached]
    solution = SimpleNamespace(steps=steps, shapes_mm=[rolled_by(10.0 - p / 10.0) for p in reached],
                               rest_weight_g=None, reason="the actuator loses stability at ... (stood in for)")
    monkeypatch.setattr(pnmold.design_fe, "run_fe",
                        lambda *a, **k: SimpleNamespace(solution=solution, mesh=SimpleNamespace(nodes_mm=nodes)))
    got = probes.roll_probe(design)
    assert [s["pressure_kpa"] for s in got.probe_roll["pressed"]] == pytest.approx(asked[:3])
    assert got.probe_roll["stopped"]["pressure_kpa"] == pytest.approx(reached[-1])
    assert "loses stability" in got.probe_roll["stopped"]["reason"]
    assert got.roll_stiffening["pressure_kpa"] == pytest.approx(asked[:3])
