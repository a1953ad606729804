"""Run CalculiX (``ccx``, Debian package ``calculix-ccx``) on an exported deck and read its tip.

``ccx -i JOB`` runs in the deck's folder and writes ``JOB.dat`` (the ``*NODE PRINT`` of the
``TIP`` set at the deck's ``*TIME POINTS, NAME=TARGETS``: after gravity, then at each
pressure), ``JOB.frd`` (fields at the same times), ``JOB.sta``/``JOB.cvg`` (increments and
iterations) and, from here, ``JOB.log`` (its console output).
"""

from __future__ import annotations

import logging
import os
import re
import shutil
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pnmold.errors import SolveError, UsageError
from pnmold.fsutil import write_text

log = logging.getLogger(__name__)

CCX_ENV = "PNMOLD_CCX"
NOT_FOUND = "CalculiX not found (install the Debian package calculix-ccx, or set PNMOLD_CCX)"
_BLOCK = re.compile(r"^\s*displacements \(vx,vy,vz\) for set (\S+) and time\s+(\S+)", re.MULTILINE)


def find_ccx() -> str | None:
    """The ``ccx`` executable (``$PNMOLD_CCX`` or ``ccx`` on the PATH), or None."""
    return shutil.which(os.environ.get(CCX_ENV, "ccx"))


@dataclass(frozen=True)
class CcxRun:
    """A finished CalculiX job.

    Attributes
    ----------
    deck : the ``.inp`` that was run.
    tip_mm : (n, 3) displacement of the ``TIP`` node at each target time of the deck.
    times : those times (the deck's load history: :func:`.abaqus.load_history`).
    seconds : wall time of the run.
    increments : converged increments (from the ``.sta`` file).
    """

    deck: Path
    tip_mm: np.ndarray
    times: np.ndarray
    seconds: float
    increments: int


def run_ccx(deck: str | Path, *, threads: int | None = None, timeout_s: float = 3600.0) -> CcxRun:
    """Run ``ccx`` on ``deck`` (in its folder) and read the tip at the end of every step.

    Raises
    ------
    UsageError : ``ccx`` is not installed.
    SolveError : CalculiX stopped with an error, did not finish every step, or timed out.
    """
    exe = find_ccx()
    if exe is None:
        raise UsageError(NOT_FOUND)
    deck = Path(deck).resolve()
    job = deck.with_suffix("")
    targets = target_times(deck.read_text())
    env = dict(os.environ)
    if threads:
        env.update(OMP_NUM_THREADS=str(threads), CCX_NPROC_EQUATION_SOLVER=str(threads),
                   CCX_NPROC_STIFFNESS=str(threads), CCX_NPROC_RESULTS=str(threads))
    t0 = time.perf_counter()
    try:
        done = subprocess.run([exe, "-i", job.name], cwd=deck.parent, env=env, capture_output=True,
                              text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired as err:
        raise SolveError(f"CalculiX on {deck.name}: no result after {timeout_s:g} s") from err
    seconds = time.perf_counter() - t0
    output = done.stdout + done.stderr
    write_text(deck.parent / f"{job.name}.log", output)
    errors = [line.strip() for line in output.splitlines() if "*ERROR" in line]
    times, tips = read_tip(job.with_suffix(".dat"))
    found = [int(np.argmin(np.abs(times - t))) for t in targets if len(times) and np.abs(times - t).min() < 1e-6]
    if errors or done.returncode != 0 or len(found) < len(targets):
        last = float(times[-1]) if len(times) else 0.0
        reason = errors[0] if errors else (f"exit code {done.returncode}" if done.returncode else
                                           f"{len(found)} of {len(targets)} target times reached")
        raise SolveError(f"CalculiX on {deck.name}: {reason} (see {job.name}.log)", last_converged=last)
    log.info("ccx %s: %d target times in %.1f s", deck.name, len(targets), seconds)
    return CcxRun(deck, tips[found], times[found], seconds, _increments(job.with_suffix(".sta")))


def target_times(deck_text: str) -> np.ndarray:
    """The times of a deck's ``*TIME POINTS, NAME=TARGETS`` (empty when it has none)."""
    m = re.search(r"^\*TIME POINTS, NAME=TARGETS\s*\n((?:[^*\n][^\n]*\n)+)", deck_text, flags=re.MULTILINE)
    if m is None:
        return np.zeros(0)
    return np.array([float(v) for v in re.split(r"[,\s]+", m.group(1).strip()) if v])


def read_tip(dat: str | Path, set_name: str = "TIP") -> tuple[np.ndarray, np.ndarray]:
    """(times, (n, 3) displacements) of the one node of ``set_name`` in a ``.dat`` file's
    ``*NODE PRINT`` blocks (empty when the file is missing)."""
    path = Path(dat)
    if not path.is_file():
        return np.zeros(0), np.zeros((0, 3))
    text = path.read_text()
    times, values = [], []
    for m in _BLOCK.finditer(text):
        if m.group(1).upper() != set_name.upper():
            continue
        rest = text[m.end():].lstrip("\n").splitlines()
        row = next((r.split() for r in rest if r.strip()), None)
        if row is None or len(row) < 4:
            continue
        times.append(float(m.group(2)))
        values.append([float(v) for v in row[1:4]])
    return np.array(times), np.array(values).reshape(-1, 3)


def read_displacements(frd: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(times, (k, n, 3) displacements of nodes 1..n) of the ``DISP`` blocks of a ``.frd`` result
    file (its ``*NODE FILE`` output; nodes it does not list are 0; empty when the file is missing)."""
    path = Path(frd)
    if not path.is_file():
        return np.zeros(0), np.zeros((0, 0, 3))
    times, blocks, rows, time, reading = [], [], None, 0.0, False
    for line in path.read_text().splitlines():
        if line.startswith("  100C"):
            time = float(line[12:24])
        elif line.startswith(" -4  DISP"):
            rows, reading = [], True
        elif reading and line.startswith(" -1"):
            rows.append((int(line[3:13]), *(float(line[13 + 12 * j:25 + 12 * j]) for j in range(3))))
        elif reading and line.startswith(" -3"):
            table = np.array(rows)
            disp = np.zeros((int(table[:, 0].max()), 3))
            disp[table[:, 0].astype(int) - 1] = table[:, 1:]
            times.append(time)
            blocks.append(disp)
            reading = False
    n = max((b.shape[0] for b in blocks), default=0)
    return np.array(times), np.array([np.pad(b, ((0, n - b.shape[0]), (0, 0))) for b in blocks]).reshape(-1, n, 3)


def _increments(sta: Path) -> int:
    if not sta.is_file():
        return 0
    rows = [line.split() for line in sta.read_text().splitlines()]
    return sum(1 for r in rows if len(r) >= 7 and r[0].isdigit() and r[1].isdigit())


@dataclass(frozen=True)
class TipComparison:
    """The tip of pnmold's FE and of CalculiX on the same exported problem (mm, frame of
    docs/frame-and-units.md, x and z), at ``pressures_kpa``.

    ``pnmold_mm`` is the run being compared (mean-dilatation volumetric term);
    ``pointwise_mm`` the same mesh and loads solved by pnmold with the pointwise penalty that
    CalculiX's C3D10 uses (None when not asked for), ``pointwise_shapes_mm`` its mesh nodes'
    displacements at those pressures ((k, n, 3), None with it).
    """

    pressures_kpa: np.ndarray
    rest_mm: np.ndarray
    pnmold_mm: np.ndarray
    calculix_mm: np.ndarray
    pointwise_mm: np.ndarray | None
    calculix: CcxRun
    pointwise_s: float | None
    pointwise_shapes_mm: np.ndarray | None = None

    def travel_mm(self, which: str = "pnmold") -> np.ndarray:
        """How far the tip has moved from rest (``which``: ``pnmold`` or ``pointwise``)."""
        return np.linalg.norm(self._tips(which) - self.rest_mm, axis=1)

    def error_fraction(self, which: str = "pnmold") -> np.ndarray:
        """|tip_CalculiX - tip_which| / travel_which at each pressure."""
        tips = self._tips(which)
        return np.linalg.norm(self.calculix_mm - tips, axis=1) / np.maximum(self.travel_mm(which), 1e-12)

    def _tips(self, which: str) -> np.ndarray:
        if which == "pointwise":
            if self.pointwise_mm is None:
                raise UsageError("this comparison was made without the pointwise pnmold solve")
            return self.pointwise_mm
        return self.pnmold_mm


#: the pointwise solve's predictor: second order. The default fourth-order
#: extrapolation overshoots the locking pointwise penalty's volumetric strain, whose predicted
#: tangents then lose stability at short steps (coarse fPN to 6 kPa, 2026-12-03: 280
#: factorisations and 81 cuts at order 4, 40 at order 1, 16 at order 2; the same 50.1 deg)
POINTWISE_PREDICTOR_ORDER = 2


def compare_with_calculix(run, folder: str | Path, pressures_kpa, *, options=None, pointwise: bool = True,
                          threads: int | None = None) -> TipComparison:
    """Export ``run``'s problem (a :class:`pnmold.design_fe.FeRun`: its mesh, material, paper and
    gravity) at ``pressures_kpa`` into ``folder/actuator.inp``, run CalculiX on it and set its
    tip beside the run's (and, with ``pointwise``, beside pnmold's solve with the pointwise
    volumetric penalty of CalculiX's C3D10, with pnmold's self-contact at the deck's penalty where
    the deck has contact pairs). The run must have converged at those pressures."""
    import dataclasses

    from pnmold.fem import SelfContact, solve_bending
    from pnmold.fem.newton import NewtonOptions
    from pnmold.fem.solver import SolveOptions

    from .abaqus import write_abaqus
    from .p2 import quadratic_mesh

    targets = sorted(float(p) for p in pressures_kpa if p > 0)
    material, membrane, regions = run.problem.material, run.problem.membrane, run.problem.regions
    wanted = ([0.0] if run.gravity_g is not None else []) + targets

    def at_wanted(steps, values) -> np.ndarray:
        by_p = {round(s.pressure_kpa, 9): v for s, v in zip(steps, values, strict=True)}
        missing = [p for p in wanted if round(p, 9) not in by_p]
        if missing:
            raise UsageError(f"the FE curve has no converged step at {missing} kPa")
        return np.array([by_p[round(p, 9)] for p in wanted])

    def tips_at(steps) -> np.ndarray:
        return at_wanted(steps, [(s.tip_x_mm, s.tip_z_mm) for s in steps])

    ours = tips_at(run.solution.steps)
    deck = write_abaqus(Path(folder) / "actuator.inp", quadratic_mesh(run.mesh), material, membrane,
                        pressures_kpa=targets, gravity_g=run.gravity_g, options=options,
                        title=f"pnmold {run.design.name}: comparison with pnmold's FE", regions=regions)
    ccx = run_ccx(deck, threads=threads)
    rest = np.array([run.mesh.tip_mm[0], run.mesh.tip_mm[2]])
    theirs = ccx.tip_mm[:, [0, 2]] + rest
    penalty, seconds, shapes = None, None, None
    k = getattr(options, "contact_mpa_per_mm", None)
    contact = SelfContact(penalty_mpa_per_mm=k) if k is not None else None
    if pointwise:
        t0 = time.perf_counter()
        sol = solve_bending(run.mesh, dataclasses.replace(material, volumetric="penalty"), membrane,
                            pressures_kpa=targets, gravity=run.gravity_g,
                            options=SolveOptions(newton=NewtonOptions(predictor_order=POINTWISE_PREDICTOR_ORDER),
                                                 self_contact=contact),
                            regions={k: dataclasses.replace(m, volumetric="penalty") for k, m in regions.items()})
        seconds = time.perf_counter() - t0
        penalty, shapes = tips_at(sol.steps), at_wanted(sol.steps, sol.shapes_mm)
    return TipComparison(np.array(wanted), rest, ours, theirs, penalty, ccx, seconds, shapes)
