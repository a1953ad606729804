"""``pnmold simulate``: the quasi-static response of a design, as JSON and as a recording.

Two models give the same rows (docs/cli.md, docs/json-schemas.md):

- ``--model fe`` builds the design's CAD, meshes the exported STEP and solves the pressure
  curve (free bending, or blocked force against a plane at the tip). The catalogue's
  effects that the FE carries enter the solve: ``gravity`` (value x g along the
  orientation), ``strain_stiffening`` (Yeoh C20/C30 added) and ``layer_compliance`` (the
  paper's E*t in series with the added compliance); cycles repeat the elastic curve.
- ``--model rom`` runs :class:`pnmold.physics.ReducedModel` (characterised by the FE once,
  cached) with every catalogued effect, history ones (``mullins``, ``viscoelasticity``)
  included.

Synthetic lab data: ``noisy_columns`` adds Gaussian noise to a recording's measured
columns (seeded).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pnmold.conventions import FULL_BEND_DEG, NO_GRAVITY, QUASI_STATIC_KINDS, check_orientation, full_bend_crossing
from pnmold.design import Design, digest
from pnmold.errors import SolveError, UsageError
from pnmold.tetmesh import MeshSize

SCHEMA = "pnmold.simulation/1"
MODELS = ("fe", "rom")
#: rows the reduced model solves at once in a simulation: its working arrays take about 9 kB a row at their
#: peak (measured at 100 000 rows, benchmarks/big_recording.py), so a longer protocol is solved in stretches
ROM_ROWS_AT_ONCE = 10_000
#: effects whose state follows the whole pressure history (the protocol cannot be cut), and the most rows
#: solved at once with one of them on (about 0.9 GB)
HISTORY_EFFECTS = ("mullins", "viscoelasticity")
HISTORY_ROWS = 100_000
_STEP_KEYS = ("pressure_kpa", "tip_x_mm", "tip_z_mm", "bend_angle_deg", "cavity_volume_ml", "max_principal_stretch")


@dataclass(frozen=True)
class SimulationRequest:
    pressures_kpa: tuple[float, ...]
    model: str = "fe"
    kind: str = "bending"
    cycles: int = 1
    orientation: str = "chambers_up"
    effects: tuple[tuple[str, float], ...] = ()
    rate_kpa_per_s: float | None = None
    mesh_size: tuple[float, float] | None = None  # FE mesh (wall, max) mm; None: the model's default
    self_contact: bool = False  # the FE's walls kept apart (pnmold.fem.SelfContact); --model fe only

    def __post_init__(self) -> None:
        if self.model not in MODELS:
            raise UsageError(f"--model: one of {', '.join(MODELS)}, got {self.model!r}")
        if self.kind not in QUASI_STATIC_KINDS:
            raise UsageError(f"--kind: one of {', '.join(QUASI_STATIC_KINDS)}, got {self.kind!r}")
        if self.cycles < 1:
            raise UsageError("--cycles must be at least 1")
        if self.rate_kpa_per_s is not None and not (self.rate_kpa_per_s > 0 and math.isfinite(self.rate_kpa_per_s)):
            raise UsageError(f"--rate-kpa-per-s must be > 0, got {self.rate_kpa_per_s:g}")
        check_orientation(self.orientation)
        if self.self_contact and self.model != "fe":
            raise UsageError("--self-contact: the FE's self-contact (--model fe); the reduced model has the "
                             "self_contact effect (--effects self_contact=...)")


@dataclass(frozen=True)
class Noise:
    """Seeded Gaussian noise of a synthetic recording (standard deviations: tip mm, volume mL, force N)."""

    mm: float = 0.0
    ml: float = 0.0
    n: float = 0.0
    seed: int | None = None

    def __post_init__(self) -> None:
        for name in ("mm", "ml", "n"):
            if not (getattr(self, name) >= 0 and math.isfinite(getattr(self, name))):
                raise UsageError(f"--noise-{name}: must be >= 0, got {getattr(self, name):g}")

    def __bool__(self) -> bool:
        return bool(self.mm or self.ml or self.n)


@dataclass(frozen=True)
class Simulation:
    """A simulation's document (``pnmold.simulation/1``) and the files written. In a notebook it shows
    a short summary; :meth:`figure` draws its curve, :meth:`steps_frame` gives its rows as a DataFrame."""

    doc: dict[str, Any]
    written: tuple[Path, ...] = ()

    def summary(self) -> dict[str, str]:
        """Label -> value: the design, model, effects, rows, the full bend and the last row."""
        d, steps = self.doc, self.doc["steps"]
        effects = ", ".join(f"{k}={v:g}" for k, v in d["effects"].items()) or "none"
        fb = d.get("full_bend_pressure_kpa")
        rows = {"design": f"{d['design']['name']} ({d['design']['digest']})",
                "model": f"{d['model']}, {d['kind']}, {d['orientation']}", "effects": effects,
                "rows": (f"{len(steps)}, {min(s['pressure_kpa'] for s in steps):g} to "
                         f"{max(s['pressure_kpa'] for s in steps):g} kPa") if steps else "0",
                "full bend": f"{fb:.1f} kPa" if fb is not None else f"- ({d.get('reason')})"}
        if steps:
            rows["last row"] = _row_text(d["kind"], steps[-1])
        if self.written:
            rows["files"] = ", ".join(str(p) for p in self.written)
        return rows

    def __repr__(self) -> str:
        s = self.summary()
        return f"<Simulation {s['design']}, {s['model']}: {s['rows']}; full bend {s['full bend']}>"

    def _repr_html_(self) -> str:
        from pnmold.frames import summary_html

        return summary_html("pnmold simulate", self.summary())

    def figure(self, *, ax=None):
        """The curve as a matplotlib Figure (:func:`pnmold.plots.plot_simulation`)."""
        from pnmold.plots import plot_simulation

        return plot_simulation(self.doc, ax=ax)

    def steps_frame(self):
        """The rows (``doc["steps"]``) as a pandas DataFrame (UsageError without pandas: ``pnmold[pandas]``)."""
        from pnmold.frames import dataframe

        return dataframe(self.doc["steps"])


def _row_text(kind: str, row: dict[str, Any]) -> str:
    at = f"at {row['pressure_kpa']:g} kPa"
    if kind == "force":
        return f"{row['force_n']:.3g} N {at}"
    if kind == "pv":
        volume = row.get("volume_ml", row["cavity_volume_ml"])
        return f"{volume:.3g} mL {at}"
    return f"bend {row['bend_angle_deg']:.1f} deg, tip ({row['tip_x_mm']:.1f}, {row['tip_z_mm']:.1f}) mm {at}"


def simulate(design: Design, request: SimulationRequest, *, json_path: str | Path | None = None,
             recording_path: str | Path | None = None, noise: Noise | None = None,
             progress: Callable[[str], None] | None = None, vtu_dir: str | Path | None = None) -> Simulation:
    """Solve the request with its model (``rom`` characterises the design first, cached, with
    ``progress``) and write the JSON and/or the recording (with ``noise``), atomically; with
    ``vtu_dir`` (FE only) also the field of every converged step for ParaView (:func:`simulate_fe`)."""
    from pnmold.fsutil import write_json
    from pnmold.recording import write_recording

    if vtu_dir is not None and request.model != "fe":
        raise UsageError("--vtu: only the FE model (--model fe) has fields to write")
    if request.model == "rom":
        from pnmold.physics.probes import characterised_for

        named = dict(request.effects)
        c = characterised_for(design, [request.kind], [request.orientation],
                              layer=named.get("layer_compliance", 0) > 0, contact=named.get("self_contact", 0) > 0,
                              size=_mesh_size(request, None, rom=True), progress=progress)
        doc = simulate_rom(design, request, c)
    else:
        doc = simulate_fe(design, request, vtu_dir=vtu_dir)
    written = [Path(doc["paraview"]["pvd"])] if vtu_dir is not None else []
    if json_path:
        written.append(write_json(json_path, doc))
    if recording_path and not doc["steps"]:
        raise SolveError(f"{recording_path}: not written, the {request.model.upper()} solved no row to record: "
                         f"{doc['reason']}", stage="recording")
    if recording_path:
        noise = noise or Noise()
        columns = noisy_columns(recording_columns(doc), noise_mm=noise.mm, noise_ml=noise.ml, noise_n=noise.n,
                                seed=noise.seed)
        written.append(write_recording(recording_path, request.kind, columns, recording_metadata(doc, request, noise)))
    return Simulation(doc, tuple(written))


def recording_metadata(doc: dict[str, Any], request: SimulationRequest, noise: Noise) -> dict[str, str]:
    """The metadata a synthetic recording carries: design, orientation, model, effects, rate, noise."""
    meta = {"design": doc["design"]["name"], "orientation": request.orientation, "model": doc["model"]}
    if request.effects:
        meta["effects"] = ",".join(f"{k}={v:g}" for k, v in request.effects)
    if request.rate_kpa_per_s:
        meta["rate_kpa_per_s"] = f"{request.rate_kpa_per_s:g}"
    if noise:
        meta["noise"] = f"mm={noise.mm:g};ml={noise.ml:g};n={noise.n:g};seed={noise.seed}"
    return meta


def parse_pressures(text: str) -> tuple[float, ...]:
    """``A:B:STEP`` -> (A, A+STEP, ..., B) in kPa."""
    try:
        a, b, step = (float(x) for x in text.split(":"))
    except ValueError:
        raise UsageError(f"--pressures: expected A:B:STEP in kPa, got {text!r}") from None
    if not (step > 0 and b > a >= 0 and math.isfinite(b)):
        raise UsageError(f"--pressures: need 0 <= A < B and STEP > 0, got {text!r}")
    n = int(math.floor((b - a) / step + 1e-9))
    values = [a + i * step for i in range(n + 1)]
    if values[-1] < b - 1e-9:
        values.append(b)
    return tuple(round(v, 9) for v in values)


def parse_effects(text: str | None) -> tuple[tuple[str, float], ...]:
    """``NAME=VALUE,NAME.PARAM=VALUE,...`` -> ((name, value), ...) (names checked by the models)."""
    if not text:
        return ()
    out = []
    for item in text.split(","):
        if "=" not in item:
            raise UsageError(f"--effects: expected NAME=VALUE, got {item!r}")
        name, value = item.split("=", 1)
        try:
            out.append((name.strip(), float(value)))
        except ValueError:
            raise UsageError(f"--effects: {name.strip()} needs a number, got {value!r}") from None
    return tuple(out)


def _mesh_size(request: SimulationRequest, default: MeshSize | None = None, rom: bool = False) -> MeshSize | None:
    """The request's mesh; else ``default`` (the reduced model: the characterisation's own)."""
    if request.mesh_size is None:
        return None if rom else (default or MeshSize())
    return MeshSize(*request.mesh_size)


def simulate_fe(design: Design, request: SimulationRequest, *, vtu_dir: str | Path | None = None) -> dict[str, Any]:
    """Solve with the FE model; return the ``pnmold.simulation/1`` document. With ``vtu_dir``
    write every converged step there as VTU with a ``.pvd`` index (``bending.pvd``, or
    ``force.pvd`` for blocked force; :mod:`pnmold.export.vtu`), named in the document's
    ``paraview``."""
    from pnmold.design_fe import run_fe
    from pnmold.fem import SelfContact, SolveOptions

    run = run_fe(design, orientation=request.orientation, effects=dict(request.effects),
                 pressures_kpa=request.pressures_kpa, kind="force" if request.kind == "force" else "bending",
                 size=_mesh_size(request),
                 options=SolveOptions(self_contact=SelfContact()) if request.self_contact else None)
    sol = run.solution
    paraview = {}
    if vtu_dir is not None:
        from pnmold.export.vtu import write_vtu_series

        index = write_vtu_series(run.mesh, sol, vtu_dir, name="force" if request.kind == "force" else "bending")
        paraview = {"paraview": {"pvd": str(index), "steps": len(sol.steps)}}
    wanted = set(np.round(request.pressures_kpa, 6))
    # a rest that carries only part of the weight (the body lost stability under it) is no state of the rig
    whole = sol.rest_weight_g is None
    inflate = [s.as_dict() for s in sol.steps if whole and round(s.pressure_kpa, 6) in wanted]
    steps = _with_time(_cycled(inflate, request.cycles), request.rate_kpa_per_s)
    return {"schema": SCHEMA, "design": {"name": design.name, "digest": digest(design)}, "model": "fe",
            "kind": request.kind, "orientation": request.orientation if run.gravity_g else NO_GRAVITY,
            "effects": dict(request.effects), "steps": steps, "full_bend_pressure_kpa": sol.full_bend_pressure_kpa,
            "reason": sol.reason, "self_contact": request.self_contact, **paraview}


def simulate_rom(design: Design, request: SimulationRequest, characterisation=None) -> dict[str, Any]:
    """Run the reduced model (characterising the design first, cached); the same document."""
    from pnmold.effects import check_effects
    from pnmold.physics import Protocol, ReducedModel

    effects = check_effects(dict(request.effects), model="rom")
    if characterisation is None:
        from pnmold.physics.probes import characterised_for

        characterisation = characterised_for(design, [request.kind], [request.orientation],
                                             layer=dict(request.effects).get("layer_compliance", 0) > 0,
                                             contact=dict(request.effects).get("self_contact", 0) > 0,
                                             size=_mesh_size(request, rom=True))
    model = ReducedModel.for_design(design, characterisation)
    protocol = Protocol.from_pressures(request.kind, request.pressures_kpa, request.cycles,
                                       request.rate_kpa_per_s, request.orientation)
    out, past = _run_to_maximum(model, protocol, effects)
    # a P-V row also carries the volume the rig reads (the reduced model's dead volume and air in it)
    keys = [*_STEP_KEYS, *({"force": ["force_n"], "pv": ["volume_ml"]}.get(request.kind, []))]
    steps = [{k: round(float(out[k][i]), 6) for k in keys} for i in range(len(protocol))]
    if request.cycles > 1:
        for i, s in enumerate(steps):
            s.update(cycle=int(protocol.cycle[i]), phase=str(protocol.phase[i]))
    steps = _with_time(steps, request.rate_kpa_per_s)
    steps = [s for s, beyond in zip(steps, past, strict=True) if not beyond]
    fb, reason = _full_bend(steps)
    if past.any():
        reason = _past_end_reason(characterisation, past, model.contact if effects.get("self_contact", 0) > 0 else None)
    curled = [s for s in steps if s["bend_angle_deg"] > FULL_BEND_DEG]
    if curled:  # the free end has met the clamped end: a physical stop, not a bend the rod may go on with
        steps = [s for s in steps if s["bend_angle_deg"] <= FULL_BEND_DEG]
        reason = "; ".join(filter(None, [reason, (
            f"{len(curled)} row(s) from {min(s['pressure_kpa'] for s in curled):g} kPa lie past full bend "
            f"({FULL_BEND_DEG:g} deg: the free end meets the clamped end, a physical stop) and are left out")]))
    return {"schema": SCHEMA, "design": {"name": design.name, "digest": digest(design)}, "model": "rom",
            "kind": request.kind, "orientation": request.orientation, "effects": effects, "steps": steps,
            "full_bend_pressure_kpa": fb, "reason": reason,
            "characterisation": {"source": characterisation.source, "mesh": characterisation.mesh,
                                 "max_pressure_kpa": characterisation.max_pressure_kpa,
                                 "probe_gravity_g": characterisation.probe_gravity_g}}


def _run_to_maximum(model, protocol, effects) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The reduced model's rows, and which lie past the FE's last solved step (its pressure maximum: no
    equilibrium there under pressure control; full bend, a physical stop or the pressure cap: the law is
    not read past it): left out of the document, said in its reason. Any other row without an
    equilibrium is an error, as before. A protocol longer than :data:`ROM_ROWS_AT_ONCE` is solved in
    stretches of that many rows when no history effect is on (each row's state is its pressure's alone:
    the same rows), so its memory does not grow with the rows; with one on it is refused past
    :data:`HISTORY_ROWS`."""
    n = len(protocol)
    if n <= ROM_ROWS_AT_ONCE:
        return _run_whole(model, protocol, effects)
    history = [name for name in HISTORY_EFFECTS if effects.get(name, 0.0) > 0]
    if history:
        if n > HISTORY_ROWS:
            raise UsageError(f"--pressures and --cycles give {n} rows; with {', '.join(history)} on, the reduced "
                             f"model follows the whole pressure history and solves every row at once (about 9 kB "
                             f"of memory a row): at most {HISTORY_ROWS}. Use a coarser --pressures STEP.")
        return _run_whole(model, protocol, effects)
    parts = []
    for a in range(0, n, ROM_ROWS_AT_ONCE):
        out, past = _run_whole(model, _rows(protocol, a, min(a + ROM_ROWS_AT_ONCE, n)), effects)
        # copies: a column that is a view (the tip, of the rod's (rows, nodes, 2) array) keeps all it views
        parts.append(({k: np.array(v) for k, v in out.items()}, past))
    out = {k: np.concatenate([part[k] for part, _ in parts]) for k in parts[0][0]}
    return out, np.concatenate([past for _, past in parts])


def _rows(protocol, a: int, b: int):
    """Rows a..b of a :class:`~pnmold.physics.Protocol` (its time, cycle and phase with them)."""
    from dataclasses import replace

    def cut(v):
        return None if v is None else v[a:b]

    return replace(protocol, pressure_kpa=protocol.pressure_kpa[a:b], time_s=cut(protocol.times_s()),
                   cycle=cut(protocol.cycle), phase=cut(protocol.phase))


def _past_end_reason(characterisation, past: np.ndarray, contact: tuple | None = None) -> str:
    """Why rows past the FE's last solved step are left out, by how the FE's curve ended; with ``contact``
    (:attr:`pnmold.physics.rom.ReducedModel.contact`: the ``self_contact`` effect on) its run's end when that
    comes first."""
    rows = f"{int(past.sum())} of {len(past)} rows"
    if contact is not None and contact[1] < characterisation.max_pressure_kpa:
        return (f"{rows} lie past where the FE's run with self-contact ended ({contact[1]:.4g} kPa on the free law: "
                f"{contact[2]}) and are left out (the law is not read past it)")
    if characterisation.ends_at_pressure_maximum:
        return f"{characterisation.reason}; {rows} lie past it and are left out (no equilibrium under pressure control)"
    return (f"{rows} lie past the last pressure the FE solved ({characterisation.max_pressure_kpa:.4g} kPa on the "
            f"free law: {characterisation.end_reason}) and are left out (the law is not read past it)")


def _run_whole(model, protocol, effects) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """:func:`_run_to_maximum` of the protocol in one piece."""
    try:
        out = model.run(protocol, effects)
    except SolveError:
        out = model.run(protocol, effects, partial=True)
        past = out["pressure_excess"] > 0
        if not np.all(np.isfinite(out["bend_angle_deg"][~past])):
            raise
        return out, past
    return out, np.zeros(len(protocol), bool)


def _full_bend(steps: list[dict[str, Any]]) -> tuple[float | None, str | None]:
    rows = [s for s in steps if s.get("phase", "inflate") == "inflate" and s.get("cycle", 1) == 1]
    fb, reason = full_bend_crossing([s["pressure_kpa"] for s in rows], [s["bend_angle_deg"] for s in rows])
    return (None if fb is None else round(fb, 6)), reason


def _cycled(inflate: list[dict[str, Any]], cycles: int) -> list[dict[str, Any]]:
    out = []
    for c in range(1, cycles + 1):
        out += [{**s, "cycle": c, "phase": "inflate"} for s in inflate]
        out += [{**s, "cycle": c, "phase": "deflate"} for s in reversed(inflate[:-1])] if cycles > 1 else []
    return out


def _with_time(steps: list[dict[str, Any]], rate_kpa_per_s: float | None) -> list[dict[str, Any]]:
    """Add ``time_s`` (pressure travelled / rate) when a ramp rate is given."""
    if not rate_kpa_per_s or not steps:
        return steps
    p = np.array([s["pressure_kpa"] for s in steps])
    t = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(p)))]) / rate_kpa_per_s
    return [{**s, "time_s": round(float(ti), 6)} for s, ti in zip(steps, t, strict=True)]


def recording_columns(doc: dict[str, Any]) -> dict[str, np.ndarray]:
    """The lab-format columns (docs/recording-format.md) of a simulation's steps."""
    steps = doc["steps"]
    col = {k: np.array([s[k] for s in steps], float) for k in steps[0] if not isinstance(steps[0][k], str | list)}
    out: dict[str, np.ndarray] = {}
    if doc["kind"] == "bending":
        for k in ("pressure_kpa", "tip_x_mm", "tip_z_mm", "bend_angle_deg"):
            out[k] = col[k]
    elif doc["kind"] == "pv":  # the volume the rig reads (the reduced model's), else the cavity's change (FE)
        cavity = col["cavity_volume_ml"] - col["cavity_volume_ml"][0]
        out["volume_ml"] = col.get("volume_ml", cavity)
        out["pressure_kpa"] = col["pressure_kpa"]
    else:
        out["pressure_kpa"] = col["pressure_kpa"]
        out["force_n"] = col["force_n"]
    if "cycle" in steps[0]:
        out["cycle"] = np.array([s["cycle"] for s in steps], int)
        out["phase"] = np.array([s["phase"] for s in steps], dtype=object)
    if "time_s" in steps[0] and doc["kind"] != "force":
        out["time_s"] = col["time_s"]
    return out


def noisy_columns(columns: dict[str, np.ndarray], *, noise_mm: float = 0.0, noise_ml: float = 0.0,
                  noise_n: float = 0.0, seed: int | None = None) -> dict[str, np.ndarray]:
    """Columns with seeded Gaussian noise of the given standard deviations on the measured
    quantities (tip coordinates in mm, injected volume in mL, force in N); pressures exact."""
    rng = np.random.default_rng(seed)
    out = dict(columns)
    for names, sigma in ((("tip_x_mm", "tip_z_mm"), noise_mm), (("volume_ml",), noise_ml), (("force_n",), noise_n)):
        if sigma < 0:
            raise UsageError(f"noise must be >= 0, got {sigma}")
        for name in names:
            if sigma and name in out:
                out[name] = out[name] + rng.normal(0.0, sigma, len(out[name]))
    return out
