"""The catalogue of physics effects (pnmold.physics.effects), `pnmold effects`, and the fingerprint
each effect leaves in the reduced model's observables.

The reduced model here runs on a characterisation built from stored FE steps:
``tests/data/fpn-free-coarse-steps.json`` is the fpn's gravity-off quick FE on the coarse mesh
(its ``produced_by`` says how; ``test_rom.py::test_stored_steps_match_the_live_fe`` checks that
the live FE still agrees). Without the FE's rod shape and probe the model spreads the bend evenly
over the chambers and takes the slab's beam compliance -- enough to show each fingerprint's
direction, which is what these tests assert.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from pnmold.cli import main
from pnmold.design import load_design
from pnmold.design_fe import design_for_fe
from pnmold.effects import EFFECTS, catalogue_json, check_effects
from pnmold.errors import DesignError, SolveError
from pnmold.physics import Protocol, ReducedModel, characterisation_from_steps
from tests.conftest import STEPS

SIX = ("gravity", "strain_stiffening", "self_contact", "layer_compliance", "mullins", "viscoelasticity")
OFF = {"gravity": 0.0}


def _at(out: dict, key: str, rows) -> np.ndarray:
    return np.asarray(out[key])[rows]


# -- the catalogue ------------------------------------------------------------------------------

def test_catalogue_lists_the_six_with_bounds():
    entries = {e["name"]: e for e in catalogue_json()}
    assert set(SIX) <= set(entries)
    for name in SIX:
        e = entries[name]
        lo, hi = e["bounds"]
        assert lo == 0.0 < hi and lo <= e["default"] <= hi, name  # 0 switches it off
        assert e["unit"] and e["parameter"] and e["description"] and e["fingerprint"], name
        assert set(e["kinds"]) <= {"bending", "pv", "force", "step"} and e["kinds"], name
        for extra in e["extra"]:
            plo, phi = extra["bounds"]
            assert plo <= extra["default"] <= phi, (name, extra)
    assert entries["gravity"]["default"] == 1.0
    assert all(entries[n]["default"] == 0.0 for n in SIX if n != "gravity")


def test_effects_verb_prints_the_catalogue(capsys):
    assert main(["effects", "--json"]) == 0
    listed = {e["name"]: e for e in json.loads(capsys.readouterr().out)}
    assert set(SIX) <= set(listed)
    assert listed["viscoelasticity"]["extra"][0]["parameter"] == "tau_s"
    assert main(["effects"]) == 0
    text = capsys.readouterr().out
    assert all(name in text for name in SIX) and "viscoelasticity.tau_s" in text


@pytest.mark.parametrize("given, field", [
    ({"nonsense": 1.0}, "effects.nonsense"),
    ({"mullins": 0.9}, "effects.mullins"),
    ({"gravity": -1.0}, "effects.gravity"),
    ({"viscoelasticity.tau": 3.0}, "effects.viscoelasticity.tau"),
    ({"viscoelasticity.tau_s": 1e4}, "effects.viscoelasticity.tau_s"),
], ids=["unknown", "mullins-high", "gravity-negative", "unknown-param", "tau-high"])
def test_check_effects_refuses_naming_the_effect(given, field):
    with pytest.raises(DesignError) as err:
        check_effects(given)
    assert err.value.field == field


def test_the_fe_carries_only_its_three():
    for name in ("self_contact", "mullins", "viscoelasticity"):
        with pytest.raises(DesignError, match=name):
            check_effects({name: 0.1}, model="fe")
    design = load_design("fpn")
    solved, g = design_for_fe(design, {"strain_stiffening": 0.03, "strain_stiffening.c30_mpa": 0.001,
                                       "layer_compliance": 0.5, "gravity": 0.5})
    assert g == 0.5
    assert solved.material.c20_mpa == pytest.approx(design.material.c20_mpa + 0.03)
    assert solved.material.c30_mpa == pytest.approx(0.001)
    et = solved.paper.modulus_mpa * solved.paper.thickness_mm  # E t in series with the added compliance
    assert 1 / et == pytest.approx(1 / (design.paper.modulus_mpa * design.paper.thickness_mm) + 0.5)
    assert design_for_fe(design, {})[0] == design


# -- value 0 is the baseline ---------------------------------------------------------------------

EXTRAS = {"strain_stiffening": {"strain_stiffening.c30_mpa": 0.0}, "mullins": {"mullins.exponent": 3.0},
          "viscoelasticity": {"viscoelasticity.tau_s": 7.0}}


@pytest.fixture(scope="module")
def fpn_bundled() -> ReducedModel:
    """The fPN's reduced model on its bundled characterisation (with the FE's run with self-contact)."""
    return ReducedModel.for_design(load_design("fpn"))


@pytest.mark.parametrize("name", [n for n in SIX if n != "gravity"])
def test_value_zero_reproduces_the_baseline(request, name):
    rom = request.getfixturevalue("fpn_bundled" if name == "self_contact" else "rom")
    top = 36 if name == "self_contact" else 45  # within the FE's run with self-contact (to 38.8 kPa)
    proto = Protocol.ramp("bending", top, 3, cycles=3, rate_kpa_per_s=4, orientation="chambers_up")
    base = rom.run(proto, {"gravity": 1.0})
    off = rom.run(proto, {"gravity": 1.0, name: 0.0, **EXTRAS.get(name, {})})
    for key in base:
        assert np.array_equal(base[key], off[key]), key
    # and switching it on a little moves the curve a little (no jump at 0)
    hi = EFFECTS[name].bounds[1]
    tiny = rom.run(proto, {"gravity": 1.0, name: 1e-7 * hi})
    assert np.abs(tiny["tip_z_mm"] - base["tip_z_mm"]).max() < 1e-3


def test_gravity_zero_is_the_fe_free_curve(rom):
    p = np.array([s["pressure_kpa"] for s in STEPS])
    out = rom.run(Protocol("bending", p, "chambers_up"), OFF)
    assert np.allclose(out["bend_angle_deg"], [s["bend_angle_deg"] for s in STEPS], atol=1e-9)
    assert np.allclose(out["cavity_volume_ml"], [s["cavity_volume_ml"] for s in STEPS], atol=1e-9)
    same = rom.run(Protocol("bending", p, "none"))
    assert all(np.array_equal(out[k], same[k]) for k in out)


# -- fingerprints -------------------------------------------------------------------------------

def test_gravity_offsets_the_tip_at_rest_and_flips_with_orientation(rom):
    ramp = {o: rom.run(Protocol.ramp("bending", 40, 2, orientation=o))
            for o in ("chambers_up", "chambers_down", "horizontal", "submerged")}
    free = rom.run(Protocol.ramp("bending", 40, 2), OFF)
    up, down = ramp["chambers_up"]["tip_z_mm"][0], ramp["chambers_down"]["tip_z_mm"][0]
    assert up < -5.0 and down > 5.0  # the weight bends the unpressurised actuator
    assert abs(up + down) < 0.3 * abs(up)  # about the same droop either way
    assert all(np.array_equal(ramp["horizontal"][k], free[k]) for k in free)  # out of plane: nothing in plane
    sub = ramp["submerged"]["tip_z_mm"][0]
    assert up < sub < 0 and abs(sub) < 0.2 * abs(up)  # buoyancy leaves about a ninth of the weight
    # chambers up: more bend at low pressure, resisted once curled past half a turn
    d = ramp["chambers_up"]["bend_angle_deg"] - free["bend_angle_deg"]
    assert d[0] > 10 and d[-1] < 0


def test_strain_stiffening_agrees_low_and_falls_short_high(rom):
    proto = Protocol.ramp("bending", 44, 1)
    base, stiff = rom.run(proto, OFF), rom.run(proto, {**OFF, "strain_stiffening": 0.05})
    shortfall = 1 - stiff["bend_angle_deg"][1:] / base["bend_angle_deg"][1:]  # relative, per pressure
    assert 0 < shortfall[0] < 0.002  # 1 kPa: the baseline (walls barely stretched)
    assert shortfall[-1] > 0.05 > 20 * shortfall[0]  # 44 kPa: clearly less bend than the baseline
    gap = base["bend_angle_deg"] - stiff["bend_angle_deg"]
    assert np.all(np.diff(gap[1:]) > -1e-9)  # the shortfall grows with pressure
    pv = rom.run(Protocol.ramp("pv", 44, 2), {**OFF, "strain_stiffening": 0.05})
    assert pv["volume_ml"][-1] < rom.run(Protocol.ramp("pv", 44, 2), OFF)["volume_ml"][-1]


def test_self_contact_is_the_fes_own_run_with_its_walls_kept_apart(fpn_bundled):
    """Free (no gravity), value 1 is the FE's free run with self-contact (read off it within a degree and a
    hundredth of a mL); below the pressure where its walls first touch nothing changes; above, the fPN bends
    further at the same pressure (its walls push the chambers apart) and half the value does half of that."""
    rom = fpn_bundled
    run = rom.characterisation.variant_runs("self_contact")[0]
    assert run["stop"] == "tip_meets_base"  # the free end meets the clamp: the run's own end
    p = run["pressure_kpa"][1:]
    free = Protocol("bending", p, "none")
    base, touch, half = (rom.run(free, {"self_contact": v}) for v in (0.0, 1.0, 0.5))
    assert np.abs(touch["bend_angle_deg"] - run["bend_angle_deg"][1:]).max() < 1.0
    assert np.abs(touch["cavity_volume_ml"] - run["cavity_volume_ml"][1:]).max() < 0.01
    more = touch["bend_angle_deg"] - base["bend_angle_deg"]
    low = p < 5.0
    assert low.sum() >= 3 and np.abs(more[low]).max() < 0.05
    assert more[(p > 15) & (p < 35)].min() > 10.0  # degrees
    extra = half["bend_angle_deg"] - base["bend_angle_deg"]
    assert np.all((extra[~low] > 0.3 * more[~low]) & (extra[~low] < 0.7 * more[~low]))


def test_past_the_end_of_the_fes_run_with_self_contact_is_out_of_reach(fpn_bundled, rom):
    """The law is not read past where the FE's run with self-contact ended (its tip met the base), and a
    model whose characterisation lacks that run refuses the effect rather than make one up."""
    end = fpn_bundled.contact[1]
    proto = Protocol("bending", np.array([0.5 * end, 1.1 * end]), "none")
    out = fpn_bundled.run(proto, {"self_contact": 1.0}, partial=True)
    assert out["pressure_excess"][0] == 0 and out["pressure_excess"][1] == pytest.approx(1 - 1 / 1.1)
    with pytest.raises(SolveError, match="self-contact"):
        fpn_bundled.run(proto, {"self_contact": 1.0})
    assert np.isfinite(fpn_bundled.run(proto, partial=True)["bend_angle_deg"]).all()
    with pytest.raises(SolveError, match="self_contact_run"):
        rom.run(proto, {"self_contact": 1.0})


def test_layer_compliance_more_bend_per_volume_on_the_same_path(rom):
    """The FE's fingerprint (benchmarks/rom.py --fe-effects layer_compliance=0.3): a softer layer bends
    the fPN further at the same pressure, with the same cavity volume, along the same tip path."""
    proto = Protocol.ramp("bending", 40, 1)
    base, soft = rom.run(proto, OFF), rom.run(proto, {**OFF, "layer_compliance": 0.3})
    gain = soft["bend_angle_deg"][1:] / base["bend_angle_deg"][1:] - 1
    assert np.all(gain > 0.02) and gain[4] > gain[-1]  # more bend, most at low pressure
    assert np.allclose(soft["cavity_volume_ml"], base["cavity_volume_ml"])  # the chambers take the same volume
    seen = soft["bend_angle_deg"] < base["bend_angle_deg"][-1]
    on_path = np.interp(soft["bend_angle_deg"][seen], base["bend_angle_deg"], base["tip_x_mm"])
    assert np.abs(on_path - soft["tip_x_mm"][seen]).max() < 0.5  # where the baseline had that bend
    more = rom.run(proto, {**OFF, "layer_compliance": 1.0})
    assert np.all(more["bend_angle_deg"][1:] > soft["bend_angle_deg"][1:])


def test_mullins_first_cycle_differs_later_cycles_repeat(rom):
    proto = Protocol.ramp("bending", 40, 2, cycles=3)
    out = rom.run(proto, {**OFF, "mullins": 0.2})
    bend = out["bend_angle_deg"]
    c, ph = proto.cycle, proto.phase

    def branch(cycle, phase):
        return bend[(c == cycle) & (ph == phase)]

    first, second, third = branch(1, "inflate"), branch(2, "inflate"), branch(3, "inflate")
    mid = len(first) // 2
    assert first[mid] < 0.9 * second[mid]  # the virgin rubber is stiffer
    assert np.allclose(second, third) and np.allclose(branch(2, "deflate"), branch(3, "deflate"))
    assert np.allclose(branch(1, "deflate"), second[-2::-1])
    assert first[-1] == pytest.approx(second[-1])  # the softened curve meets the first at the peak


def test_viscoelasticity_opens_a_loop_that_widens_with_rate(rom):
    def loop(rate):
        proto = Protocol.ramp("bending", 40, 1, cycles=2, rate_kpa_per_s=rate)
        out = rom.run(proto, {**OFF, "viscoelasticity": 0.3, "viscoelasticity.tau_s": 2.0})
        sel = proto.cycle == 2
        up = out["bend_angle_deg"][sel & (proto.phase == "inflate")]
        down = out["bend_angle_deg"][sel & (proto.phase == "deflate")][::-1]
        return up[:-1], down

    slow_up, slow_down = loop(0.5)
    fast_up, fast_down = loop(5.0)
    assert np.all(fast_down[5:-5] > fast_up[5:-5])  # deflating, the bend lags behind: more bent
    width = lambda up, down: float(np.sum(down - up))  # noqa: E731
    assert width(fast_up, fast_down) > 2 * width(slow_up, slow_down) > 0
    quasi = rom.run(Protocol.ramp("bending", 40, 1, cycles=2), {**OFF, "viscoelasticity": 0.3})
    assert np.array_equal(quasi["bend_angle_deg"], rom.run(Protocol.ramp("bending", 40, 1, cycles=2), OFF)[
        "bend_angle_deg"])  # no time, no rate: quasi-static


def test_viscoelasticity_creeps_at_a_hold(rom):
    p = np.array([0, 10, 20, 20, 20, 20], float)
    t = np.array([0, 1, 2, 4, 8, 30], float)
    out = rom.run(Protocol("bending", p, "none", time_s=t), {"viscoelasticity": 0.3})
    hold = out["bend_angle_deg"][2:]
    assert np.all(np.diff(hold) > 0)  # creeps on at constant pressure
    relaxed = rom.run(Protocol("bending", np.array([0.0, 20.0]), "none"))["bend_angle_deg"][-1]
    assert hold[-1] == pytest.approx(relaxed, rel=1e-3)


# -- simulate with effects ------------------------------------------------------------------------

@pytest.fixture
def cached_fpn(tmp_path, monkeypatch, fpn):
    """A characterisation in the cache (from the stored steps), so `simulate --model rom` needs no FE."""
    from pnmold.fsutil import write_json
    from pnmold.physics.characterise import DEFAULT_MAX_PRESSURE_KPA, DEFAULT_SIZE, cache_path

    monkeypatch.setenv("PNMOLD_CACHE", str(tmp_path / "cache"))
    path = cache_path(fpn, DEFAULT_SIZE, DEFAULT_MAX_PRESSURE_KPA)
    write_json(path, characterisation_from_steps(STEPS, fpn).to_json())
    return tmp_path


def test_simulate_rom_writes_a_recording_with_effects(cached_fpn):
    from pnmold.recording import read_recording

    rec, js = cached_fpn / "rom.csv", cached_fpn / "rom.json"
    assert main(["simulate", "fpn", "--model", "rom", "--pressures", "0:30:3", "--cycles", "2",
                 "--rate-kpa-per-s", "2", "--effects", "gravity=1,mullins=0.2,viscoelasticity=0.2,"
                 "viscoelasticity.tau_s=3", "--recording", str(rec), "--json", str(js), "--quiet"]) == 0
    recording = read_recording(rec)
    assert recording.kind == "bending" and recording.metadata["model"] == "rom"
    assert set(recording["cycle"]) == {1, 2} and recording["time_s"][-1] == pytest.approx(2 * 2 * 30 / 2)
    doc = json.loads(js.read_text())
    assert doc["model"] == "rom" and doc["effects"]["mullins"] == 0.2
    first = recording["tip_z_mm"][(recording["cycle"] == 1) & (recording["phase"] == "inflate")]
    second = recording["tip_z_mm"][(recording["cycle"] == 2) & (recording["phase"] == "inflate")]
    assert not np.allclose(first, second)  # the Mullins effect is in the data


def test_simulate_rom_force_and_pv_and_noise(cached_fpn):
    from pnmold.recording import read_recording

    files = {k: cached_fpn / f"{k}.csv" for k in ("force", "pv", "noisy", "noisy2")}
    assert main(["simulate", "fpn", "--model", "rom", "--kind", "force", "--pressures", "0:20:5",
                 "--recording", str(files["force"]), "--quiet"]) == 0
    force = read_recording(files["force"])["force_n"]
    assert force[0] > 0 and np.all(np.diff(force) > 0)  # the weight, then the pressure pushes
    assert main(["simulate", "fpn", "--model", "rom", "--kind", "pv", "--pressures", "0:20:5",
                 "--recording", str(files["pv"]), "--quiet"]) == 0
    assert read_recording(files["pv"])["volume_ml"][0] == 0.0
    for name in ("noisy", "noisy2"):
        assert main(["simulate", "fpn", "--model", "rom", "--pressures", "0:20:5", "--noise-mm", "0.5",
                     "--seed", "7", "--recording", str(files[name]), "--quiet"]) == 0
    a, b = read_recording(files["noisy"]), read_recording(files["noisy2"])
    assert np.array_equal(a["tip_x_mm"], b["tip_x_mm"])  # seeded
    clean = ReducedModel(load_design("fpn"), characterisation_from_steps(STEPS, load_design("fpn"))).run(
        Protocol.ramp("bending", 20, 5))
    assert 0 < np.abs(a["tip_x_mm"] - clean["tip_x_mm"]).max() < 3


@pytest.mark.parametrize("effects", ["nonsense=1", "mullins=3", "viscoelasticity.tau=2", "flow_restriction=1"],
                         ids=["unknown", "out-of-bounds", "unknown-param", "not-in-rom"])
def test_simulate_refuses_bad_effects(cached_fpn, capsys, effects):
    assert main(["simulate", "fpn", "--model", "rom", "--effects", effects, "--quiet"]) == 2
    assert effects.split("=")[0].split(".")[0] in capsys.readouterr().err


def test_simulate_fe_refuses_rom_only_effects_before_any_cad(capsys):
    assert main(["simulate", "fpn", "--effects", "viscoelasticity=0.2", "--quiet"]) == 2
    assert "viscoelasticity" in capsys.readouterr().err


def test_simulate_with_self_contact_stops_where_the_fes_run_with_it_ended(tmp_path):
    """``pnmold simulate --effects self_contact=1`` on the fPN (its shipped run with self-contact: no FE) leaves
    out the rows past where that run's tip met its base, and says so by that run's end, not the free run's."""
    out = tmp_path / "sim.json"
    assert main(["simulate", "fpn", "--model", "rom", "--effects", "self_contact=1", "--pressures", "0:45:5",
                 "--json", str(out), "-q"]) == 0
    doc = json.loads(out.read_text())
    end = ReducedModel.for_design(load_design("fpn")).contact[1]
    assert 35 < end < 45 and max(s["pressure_kpa"] for s in doc["steps"]) < end
    assert "run with self-contact ended" in doc["reason"] and f"{end:.4g} kPa" in doc["reason"]
