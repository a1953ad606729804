"""Long recordings: the rule that reduces them (:mod:`pnmold.recording.reduce`), that a short one is left as
it is, that averaged rows are not judged against less noise than they carry, that a long recording made from a
short one is diagnosed as the short one is; the diagnosis's kept predictions owning their memory; `pnmold
simulate` of a long protocol in stretches. Timings are in benchmarks/big_recording.py, not here."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from pnmold.cli import main
from pnmold.diagnose.data import build_dataset
from pnmold.errors import UsageError
from pnmold.recording import Recording, read_recording
from pnmold.recording import reduce as red
from pnmold.recording.reduce import AVERAGED, MAX_ROWS, reduce_recording, stretches


def _cycled(levels: int, cycles: int, repeat: int, noise: float = 0.0, seed: int = 0) -> Recording:
    """A bending recording of ``cycles`` inflations and deflations through ``levels`` pressures, each row
    repeated ``repeat`` times, the tip a line in pressure plus ``noise``."""
    up = np.linspace(0.0, 40.0, levels)
    p, cycle, phase = [], [], []
    for c in range(1, cycles + 1):
        for ph, ramp in (("inflate", up), ("deflate", up[-2::-1])):
            p += ramp.tolist()
            cycle += [c] * ramp.size
            phase += [ph] * ramp.size
    p = np.repeat(p, repeat)
    rng = np.random.default_rng(seed)
    return Recording("cycled.csv", "bending", {
        "pressure_kpa": p, "tip_x_mm": 111.0 - 2.0 * p + rng.normal(0, noise, p.size),
        "tip_z_mm": -3.0 * p + rng.normal(0, noise, p.size), "cycle": np.repeat(cycle, repeat),
        "phase": np.repeat(np.array(phase, dtype=object), repeat)}, {"kind": "bending"})


def _blocks(reduced: Recording) -> list[slice]:
    """The recorded rows each kept row averages (consecutive, in order)."""
    ends = np.cumsum(reduced[AVERAGED])
    return [slice(int(e - k), int(e)) for e, k in zip(ends, reduced[AVERAGED], strict=True)]


def test_a_recording_at_the_limit_is_left_as_it_is_and_one_row_more_is_reduced():
    limit = MAX_ROWS["bending"]
    rec = Recording("r.csv", "bending", {"pressure_kpa": np.linspace(0, 40, limit), "tip_x_mm": np.zeros(limit),
                                          "tip_z_mm": np.zeros(limit)}, {})
    same, how = reduce_recording(rec)
    assert same is rec and how is None and AVERAGED not in same.columns
    longer = Recording("r.csv", "bending", {k: np.append(v, v[-1]) for k, v in rec.columns.items()}, {})
    reduced, how = reduce_recording(longer)
    assert how is not None and len(reduced) <= limit and int(reduced[AVERAGED].sum()) == limit + 1


@pytest.mark.parametrize("n_repeat", [7, 83, 1000], ids=["7x", "83x", "1000x"])
def test_blocks_are_consecutive_means_that_never_cross_a_cycle_or_phase(n_repeat):
    rec = _cycled(levels=21, cycles=3, repeat=n_repeat, noise=0.3)
    reduced, how = reduce_recording(rec)
    n = len(rec)
    assert how.rule == "block_mean" and how.rows_recorded == n and how.rows == len(reduced) <= MAX_ROWS["bending"]
    k = how.parameter
    assert int(reduced[AVERAGED].max()) <= k and k >= math.ceil(n / MAX_ROWS["bending"])
    lengths = [b - a for a, b in stretches(rec)]
    assert sum(-(-m // (k - 1)) for m in lengths) > MAX_ROWS["bending"] or k == math.ceil(n / MAX_ROWS["bending"])
    assert len(lengths) == 6  # 3 cycles x (inflate, deflate)
    for i, rows in enumerate(_blocks(reduced)):
        assert len(set(rec["cycle"][rows])) == 1 and len(set(rec["phase"][rows])) == 1
        assert reduced["cycle"][i] == rec["cycle"][rows][0] and reduced["phase"][i] == rec["phase"][rows][0]
        for name in ("pressure_kpa", "tip_x_mm", "tip_z_mm"):
            assert reduced[name][i] == pytest.approx(rec[name][rows].mean(), abs=1e-9)
    assert int(reduced[AVERAGED].sum()) == n


def test_a_turn_of_the_pressure_ends_a_stretch_and_its_noise_does_not():
    """Without cycle and phase columns: up, down, up, down, with a transducer's noise (0.5 % of the span)."""
    rows = 4000
    true = np.concatenate([np.linspace(0, 40, rows), np.linspace(40, 0, rows)] * 2)
    p = true + np.random.default_rng(3).normal(0, 0.2, true.size)
    rec = Recording("tri.csv", "bending", {"pressure_kpa": p, "tip_x_mm": p, "tip_z_mm": -p}, {})
    parts = stretches(rec)
    assert len(parts) == 4
    for (_, b), turn in zip(parts[:-1], (rows, 2 * rows, 3 * rows), strict=True):
        assert abs(b - turn) < 0.05 * rows  # cut at the turn, within the noise's reach
    reduced, _ = reduce_recording(rec)
    stretch = np.repeat(np.arange(len(parts)), [b - a for a, b in parts])
    assert all(len(set(stretch[rows_])) == 1 for rows_ in _blocks(reduced))  # no block holds rows of two ramps


def test_a_step_recording_keeps_the_rows_after_every_valve_switch():
    n, vent = 30_000, 12_000
    t = np.arange(n) / 1000.0
    supply = np.where((np.arange(n) >= 100) & (np.arange(n) < vent), 100.0, 0.0)
    p = np.where(supply > 0, 100.0 * (1 - np.exp(-(t - 0.1) / 0.05)), 0.0)
    rec = Recording("step.csv", "step", {"time_s": t, "supply_kpa": supply, "pressure_kpa": p}, {"kind": "step"})
    reduced, how = reduce_recording(rec)
    m = how.parameter
    assert how.rule == "log_time" and len(reduced) <= MAX_ROWS["step"] and how.stretches == 3 and m > 10
    switches = [0, 100, vent]
    for s in switches:  # the first m rows after every switch, as recorded
        at = int(np.searchsorted(reduced["time_s"], t[s]))
        assert np.array_equal(reduced["time_s"][at:at + m], t[s:s + m])
        assert np.all(reduced[AVERAGED][at:at + m] == 1)
    for rows in _blocks(reduced):
        assert len(set(supply[rows] > 50)) == 1  # no block crosses a switch
        since = rows.start - max(s for s in switches if s <= rows.start)
        assert rows.stop - rows.start <= max(1, since // m)


def test_averaged_rows_carry_their_noise_over_sqrt_k_and_correlated_noise_is_not_shrunk():
    """The measurement noise the diagnosis gives a kept row: white noise averaged over k rows is s / sqrt(k); a
    noise correlated over ~50 recorded rows averages down less, and the kept rows' own scatter says so (the
    recorded rows' second differences over sqrt(k) would take it for ~30 times less)."""
    n, s = 100_000, 0.3
    p = np.linspace(0.0, 40.0, n)
    rng = np.random.default_rng(5)
    white = rng.normal(0, s, n)
    walk = np.convolve(rng.normal(0, 1, n + 199), np.hanning(200), mode="valid")
    walk *= s / walk.std()
    for noise, expect in ((white, None), (walk, "correlated")):
        rec = Recording("ramp.csv", "bending", {"pressure_kpa": p, "tip_x_mm": 100 - p + noise,
                                                "tip_z_mm": -p + noise}, {})
        reduced, how = reduce_recording(rec)
        kept_noise = reduced["tip_x_mm"] - (100 - reduced["pressure_kpa"])
        base = [{"tip_x_mm": 100 - reduced["pressure_kpa"], "tip_z_mm": -reduced["pressure_kpa"]}]
        series = build_dataset([reduced], base, model_form_share=0.0, pressure_form_share=0.0).series[0]
        if expect is None:
            assert series.measurement == pytest.approx(s / math.sqrt(how.parameter), rel=0.15)
        else:
            naive = float(np.std(np.diff(noise, 2))) / math.sqrt(6) / math.sqrt(how.parameter)
            assert series.measurement > 5 * naive
            assert series.measurement == pytest.approx(float(np.std(kept_noise)), rel=0.35)


def test_a_file_too_long_to_read_is_refused_before_it_is_read(tmp_path, monkeypatch, capsys):
    path = tmp_path / "long.csv"
    path.write_text("# kind: bending\npressure_kpa,tip_x_mm,tip_z_mm\n" + "1,2,3\n" * 50)
    monkeypatch.setattr(red, "MAX_READ_ROWS", 20)
    for argv in (["recording", "check", str(path)], ["diagnose", "fpn", str(path), "--json", str(tmp_path / "d")]):
        assert main(argv) == 2
        err = " ".join(capsys.readouterr().err.split())
        assert "long.csv" in err and "52 lines, more than the 20" in err
    assert not (tmp_path / "d").exists()


def test_recording_check_says_how_a_diagnosis_reduces_a_long_recording(tmp_path, capsys):
    rec = _cycled(levels=11, cycles=1, repeat=100)
    path = tmp_path / "long.csv"
    lines = ["# kind: bending", "pressure_kpa,tip_x_mm,tip_z_mm,cycle,phase"]
    lines += [f"{p},{x},{z},{c},{ph}" for p, x, z, c, ph in zip(*(rec[k] for k in rec.columns), strict=True)]
    path.write_text("\n".join(lines) + "\n")
    assert main(["recording", "check", str(path)]) == 0
    out = " ".join(capsys.readouterr().out.split())
    expected = reduce_recording(read_recording(path))[1]
    assert f"{len(rec)} rows" in out and f"reduced to {expected.rows} rows" in out and "block of at most" in out


@pytest.mark.slow
def test_a_long_recording_made_from_a_short_one_gets_its_verdict(tmp_path, capsys, monkeypatch):
    """A short recording (3 cycles at 2 kPa steps, a concealed Mullins softening, 0.3 mm noise) and one of
    19 926 rows made from it (each row 162 times, with 0.3 mm more noise), reduced to blocks of 81 rows: the
    same effect named,
    the same verdict, the modulus within 1 % and the effect within 10 % (stated tolerances), and the JSON and
    the console say how the long one was read. The limit is set to twice the short one's 123 rows, so that
    every block lies within one of its pressures: the model solves the short one's pressures (a test's time;
    benchmarks/big_recording.py diagnoses a logger's ramp at the default limit)."""
    monkeypatch.setitem(MAX_ROWS, "bending", 2 * 123)
    short, long_, = tmp_path / "short.csv", tmp_path / "long.csv"
    assert main(["-q", "simulate", "fpn", "--model", "rom", "--kind", "bending", "--pressures", "0:40:2",
                 "--cycles", "3", "--effects", "mullins=0.3", "--noise-mm", "0.3", "--seed", "4",
                 "--recording", str(short)]) == 0
    text = short.read_text().splitlines()
    head = [line for line in text if line.startswith("#")]
    rows = text[len(head) + 1:]
    names = text[len(head)].split(",")
    rng = np.random.default_rng(1)
    out = []
    for row in rows:
        cells = row.split(",")
        for _ in range(162):
            for name in ("tip_x_mm", "tip_z_mm"):
                cells[names.index(name)] = f"{float(row.split(',')[names.index(name)]) + rng.normal(0, 0.3):.4f}"
            out.append(",".join(cells))
    long_.write_text("\n".join([*head, text[len(head)], *out]) + "\n")
    docs = {}
    for path in (short, long_):
        assert main(["diagnose", "fpn", str(path), "--json", str(path.with_suffix(".json"))]) == 0
        docs[path.stem] = json.loads(path.with_suffix(".json").read_text())
    console = " ".join(capsys.readouterr().out.split())
    a, b = docs["short"], docs["long"]
    assert [m["effect"] for m in a["missing_physics"]] == [m["effect"] for m in b["missing_physics"]] == ["mullins"]
    assert a["unexplained"] == b["unexplained"] is False
    assert b["calibration"]["final"]["modulus_scale"] == pytest.approx(a["calibration"]["final"]["modulus_scale"],
                                                                       rel=0.01)
    value = [m["parameters"]["mullins"] for m in (a["missing_physics"][0], b["missing_physics"][0])]
    assert value[1] == pytest.approx(value[0], rel=0.1)
    assert "reduction" not in a["recordings"][0]
    how = b["recordings"][0]["reduction"]
    assert how["rule"] == "block_mean" and how["rows_recorded"] == 162 * len(rows) and how["rows_per_block"] == 81
    assert b["recordings"][0]["rows"] == how["rows"] == 2 * len(rows)
    assert b["summary"].startswith(how["words"]) and " ".join(f"read {how['words']}".split()) in console


def test_kept_predictions_own_their_arrays_and_stay_within_their_bytes(monkeypatch):
    """The diagnosis's memory grew by ~0.3 MB a row: each of up to 512 kept predictions held the tip as a view
    of the model's (rows, nodes, 2) array. Kept now as arrays of their own, within a byte budget."""
    from pnmold.diagnose import fitting
    from pnmold.diagnose.fitting import Fitter, Hypothesis, Parameter

    rows = 1000
    nodes = np.zeros((rows, 20, 2))

    def forward(effects, calibration):
        return [{"tip_x_mm": nodes[:, -1, 0] + calibration["modulus_scale"]}]

    monkeypatch.setattr(fitting, "KEPT_BYTES", 10 * rows * 8)
    fitter = Fitter(None, forward)
    h = Hypothesis((), (Parameter("modulus_scale", 1.0, 0.5, 2.0, calibration=True),))
    for x in np.linspace(0.6, 1.9, 30):
        kept = fitter.predict(h, np.array([x]))
        assert kept[0]["tip_x_mm"].base is None and kept[0]["tip_x_mm"][0] == pytest.approx(x)
    assert fitter.evaluations == 30 and len(fitter._kept) == 10


def test_simulate_solves_a_long_protocol_in_stretches_to_the_same_rows(monkeypatch, fpn):
    from pnmold.simulate import SimulationRequest, parse_pressures, quasistatic

    request = SimulationRequest(parse_pressures("0:40:0.5"), "rom", "pv", cycles=2, rate_kpa_per_s=2.0)
    whole = quasistatic.simulate_rom(fpn, request)
    monkeypatch.setattr(quasistatic, "ROM_ROWS_AT_ONCE", 7)
    cut = quasistatic.simulate_rom(fpn, request)
    assert len(cut["steps"]) == len(whole["steps"]) == 2 * 2 * 81 - 2
    for a, b in zip(whole["steps"], cut["steps"], strict=True):
        assert a.keys() == b.keys() and all(a[k] == pytest.approx(b[k], abs=1e-6) for k in a)
    monkeypatch.setattr(quasistatic, "HISTORY_ROWS", 100)  # a history effect cannot be cut
    with pytest.raises(UsageError, match="mullins"):
        quasistatic.simulate_rom(fpn, SimulationRequest(request.pressures_kpa, "rom", "pv", cycles=2,
                                                        effects=(("mullins", 0.2),)))


def test_simulate_prints_the_ends_of_a_long_curve(monkeypatch, capsys):
    import pnmold.cli.simulate as cli_simulate

    monkeypatch.setattr(cli_simulate, "PRINTED_ROWS", 10)
    assert main(["simulate", "fpn", "--model", "rom", "--pressures", "0:40:0.5"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert sum("kPa: bend" in line for line in lines) == 10
    assert any("71 more rows (all 81" in line for line in lines)
