"""Independent peer for the FE benchmark: the same bending problem solved by SfePy.

SfePy (PyPI ``sfepy``, see ``benchmarks/requirements-peer.txt``; not a dependency of
pnmold) solves the problem pnmold's ``solve_bending`` solves, on the same TetMesh, with
the same quadrature, load increments and residual tolerance:

- P2 (or P1) Lagrange tetrahedra on ``mesh.tets``; volume quadrature of order 2 (the same
  4-point rule as pnmold's ``intorder=2``), facet quadrature of order 4 (6 points);
- ``dw_tl_he_genyeoh`` with (K1, K2, K3, m, p, q) = (C10, C20, C30, 1, 2, 3), i.e. the
  Yeoh energy C10 (I1b - 3) + C20 (I1b - 3)^2 + C30 (I1b - 3)^3 with I1b = J^-2/3 tr C;
- ``dw_tl_bulk_penalty`` with K = bulk_ratio * 2 C10: U = K/2 (J - 1)^2 at each quadrature
  point, which is pnmold's ``Yeoh(volumetric="penalty")``, not its default mean dilatation;
- ``dw_tl_surface_traction`` with sigma = p I on the ``cavity`` facets: the follower
  pressure p J F^-T N dA in the reference configuration (N the solid's outward normal),
  linearised in F by SfePy;
- zero displacement of every node on the ``clamp`` facets, u_y = 0 on ``symmetry``;
- SfePy's ``nls.newton`` (backtracking line search on the residual norm) with
  ``ls.pypardiso`` (MKL PARDISO), one Newton solve per load increment, and pnmold's
  tolerance: |R_free| <= rtol * max(|f_ext,free|, |R_fixed|), both norms evaluated by
  SfePy at the start of the increment.

    .venv/bin/python benchmarks/fem_peer.py [--pressure 5] [--wall 2.5 --max 5.0] [--order 2]

``compare(design, step)`` meshes and prints the comparison (what ``benchmarks/fem.py``
calls); ``solve_with_sfepy(mesh, material, p, rtol=...)`` is the peer alone.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import logging
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

if importlib.util.find_spec("sfepy") is None:  # the benchmark skips the peer on ImportError
    raise ImportError("SfePy is not installed: pip install -r benchmarks/requirements-peer.txt")

_LOG_TAIL = 80


def _facet_ids(cmesh, triangles: np.ndarray) -> np.ndarray:
    """Indices of SfePy's (cmesh) facets given as vertex triples."""
    cmesh.setup_connectivity(2, 0)
    conn = cmesh.get_conn(2, 0)
    verts = np.asarray(conn.indices, dtype=np.int64).reshape(-1, 3)
    n = int(cmesh.n_coor)
    keys = np.sort(verts, axis=1)
    keys = (keys[:, 0] * n + keys[:, 1]) * n + keys[:, 2]
    order = np.argsort(keys)
    want = np.sort(np.asarray(triangles, dtype=np.int64), axis=1)
    want = (want[:, 0] * n + want[:, 1]) * n + want[:, 2]
    pos = np.clip(np.searchsorted(keys[order], want), 0, order.size - 1)
    if np.any(keys[order][pos] != want):
        raise ValueError("a facet of the TetMesh is not a face of SfePy's mesh")
    return np.unique(order[pos])


def _build(mesh, material, order: int):
    """SfePy problem objects of the pnmold bending problem at a settable pressure."""
    from sfepy.discrete import (
        Equation,
        Equations,
        FieldVariable,
        Function,
        Integral,
        Material,
        Problem,
    )
    from sfepy.discrete.common.region import Region
    from sfepy.discrete.conditions import Conditions, EssentialBC
    from sfepy.discrete.fem import FEDomain, Field, Mesh
    from sfepy.terms import Term

    coors = np.ascontiguousarray(mesh.nodes_mm, dtype=np.float64)
    tets = np.ascontiguousarray(mesh.tets, dtype=np.int32)
    smesh = Mesh.from_data("pnmold", coors, np.zeros(len(coors), np.int32), [tets],
                           [np.zeros(len(tets), np.int32)], ["3_4"])
    domain = FEDomain("domain", smesh)
    omega = domain.create_region("Omega", "all")

    def facet_region(name: str) -> Region:
        ids = _facet_ids(domain.cmesh, mesh.facets[name])
        region = Region.from_facets(ids, domain, name=name.capitalize(), kind="facet")
        domain.regions.append(region)
        return region

    cavity = facet_region("cavity")
    field = Field.from_args("displacement", np.float64, "vector", omega, approx_order=order)
    u = FieldVariable("u", "unknown", field)
    v = FieldVariable("v", "test", field, primary_var_name="u")

    c10, c20, c30 = material.c10_mpa, material.c20_mpa, material.c30_mpa
    solid = Material("solid", yeoh=np.array([[c10, c20, c30, 1.0, 2.0, 3.0]]),
                     K=material.bulk_modulus_mpa)
    state = {"p": 0.0}

    def traction(ts, coors, mode=None, **kwargs):
        if mode != "qp":
            return None
        return {"sigma": np.tile(state["p"] * np.eye(3), (coors.shape[0], 1, 1))}

    load = Material("load", function=Function("traction", traction))
    ivol = Integral("ivol", order=2)
    isurf = Integral("isurf", order=4)
    t_yeoh = Term.new("dw_tl_he_genyeoh(solid.yeoh, v, u)", ivol, omega, solid=solid, v=v, u=u)
    t_bulk = Term.new("dw_tl_bulk_penalty(solid.K, v, u)", ivol, omega, solid=solid, v=v, u=u)
    # Residual R = f_int - f_ext with f_ext = -p J F^-T N dA on the solid: + traction(p I).
    t_press = Term.new("dw_tl_surface_traction(load.sigma, v, u)", isurf, cavity, load=load,
                       v=v, u=u)
    equations = Equations([Equation("balance", t_yeoh + t_bulk + t_press)])
    pb = Problem("pnmold_peer", equations=equations, domain=domain)
    pb.set_output_dir(tempfile.gettempdir())
    ebcs = [EssentialBC("clamp", facet_region("clamp"), {"u.all": 0.0})]
    if mesh.half:
        ebcs.append(EssentialBC("symmetry", facet_region("symmetry"), {"u.1": 0.0}))
    pb.set_bcs(ebcs=Conditions(ebcs))
    return pb, field, state, (t_yeoh, t_bulk, t_press)


def _increments(pressure_kpa: float, increments_kpa: Sequence[float] | int | None) -> list[float]:
    if increments_kpa is None:
        increments_kpa = 10
    if isinstance(increments_kpa, int):
        return [pressure_kpa * (i + 1) / increments_kpa for i in range(increments_kpa)]
    out = sorted(float(p) for p in increments_kpa if 0 < p < pressure_kpa * (1 + 1e-9))
    if not out or abs(out[-1] - pressure_kpa) > 1e-9 * pressure_kpa:
        out.append(float(pressure_kpa))
    return out


def solve_with_sfepy(mesh, material, pressure_kpa: float, *, rtol: float, order: int = 2,
                     increments_kpa: Sequence[float] | int | None = None,
                     max_iterations: int = 20, max_cuts: int = 6,
                     newton_options: dict | None = None, verbose: bool = False) -> dict:
    """Solve pnmold's free-bending problem (no membrane, no gravity) with SfePy.

    Parameters
    ----------
    mesh : a :class:`pnmold.tetmesh.TetMesh` (facet sets ``cavity``, ``clamp`` and, for a
        half model, ``symmetry``; ``tip_mm`` is followed).
    material : a :class:`pnmold.fem.Yeoh`; the volumetric part is always SfePy's pointwise
        penalty K/2 (J-1)^2 with K = ``material.bulk_modulus_mpa`` (compare with pnmold's
        ``volumetric="penalty"``).
    pressure_kpa : the final cavity pressure.
    rtol : Newton tolerance, as pnmold's ``NewtonOptions.rtol``.
    order : 2 (P2, as pnmold) or 1.
    increments_kpa : the pressures of the load increments (e.g. the ones pnmold converged
        at), or their number (equal increments); default 10 equal increments.
    max_iterations : Newton iterations allowed per increment.
    max_cuts : a failed increment is halved at most this many times in a row.
    newton_options : overrides of SfePy's ``nls.newton`` settings.
    verbose : print one line per increment to stderr.

    Returns
    -------
    dict with ``ok``, ``pressure_kpa`` (last converged), ``tip_mm`` (x, y, z of the followed
    ``mesh.tip_mm``), ``tip_displacement_mm``, ``dofs`` (free unknowns), ``increments``
    (converged), ``cuts``, ``newton_iterations`` (per converged increment),
    ``factorizations`` (all Newton iterations, failed increments included), ``time_s``
    (setup and solve), ``setup_s``, ``solve_s``, ``nls_time_s`` (SfePy's own
    residual/matrix/solve split) and ``log`` (the tail of what SfePy printed).
    """
    with contextlib.redirect_stdout(io.StringIO()):  # SfePy's notes on optional backends
        from sfepy.base.base import IndexedStruct, output
        from sfepy.solvers.ls import PyPardisoSolver
        from sfepy.solvers.nls import Newton
        from sfepy.terms import Term  # noqa: F401

    if order not in (1, 2):
        raise ValueError(f"order must be 1 or 2, got {order}")
    if not pressure_kpa > 0:
        raise ValueError(f"pressure_kpa must be > 0, got {pressure_kpa}")
    targets = _increments(float(pressure_kpa), increments_kpa)
    buffer = io.StringIO()
    output.set_output(filename=buffer, quiet=True)
    t0 = time.perf_counter()
    pb, field, state, (_, _, t_press) = _build(mesh, material, order)
    ls = PyPardisoSolver({})
    nls_status = IndexedStruct()
    nls = Newton({"i_max": max_iterations, "eps_a": 1e-10, "eps_r": 1.0, "eps_mode": "and",
                  "macheps": 1e-30, "lin_red": None, "ls_red": 0.5, "ls_red_warp": 0.1,
                  "ls_min": 1e-5, "ls_on": 100.0, **(newton_options or {})},
                 lin_solver=ls, status=nls_status)
    pb.set_solver(nls)
    pb.time_update()
    variables = pb.get_initial_state()
    variables.apply_ebc()
    vec = variables.get_state(False, force=True).copy()
    dofs = int(pb.equations.variables.adi.n_dof_total)
    setup_s = time.perf_counter() - t0

    eq_map = pb.get_variables()["u"].eq_map
    fixed = np.zeros(eq_map.eq.shape[0], bool)
    fixed[eq_map.eq_ebc] = True

    def norms(vec_full: np.ndarray) -> tuple[float, float]:
        """|f_ext| on the free dofs and |R| on the fixed ones (reactions) at ``vec_full``."""
        pb.equations.variables.set_state(vec_full, False, force=True)
        kw = {"mode": "weak", "dw_mode": "vector", "u": pb.get_variables()["u"],
              "copy_materials": False, "active_only": False, "verbose": False}
        f_press = pb.evaluate("dw_tl_surface_traction.4.Cavity(load.sigma, v, u)", **kw)
        f_int = pb.evaluate("dw_tl_he_genyeoh.2.Omega(solid.yeoh, v, u)"
                            " + dw_tl_bulk_penalty.2.Omega(solid.K, v, u)", **kw)
        return (float(np.linalg.norm(f_press[~fixed])),
                float(np.linalg.norm((f_int + f_press)[fixed])))

    iterations: list[int] = []
    nls_time = {"residual": 0.0, "matrix": 0.0, "solve": 0.0}
    p_done, cuts, total_cuts, total_its, ok = 0.0, 0, 0, 0, True
    t_solve = time.perf_counter()
    queue = list(targets)
    while queue:
        p_new = queue[0]
        state["p"] = p_new / 1000.0
        pb.solver.nls.conf.eps_a = rtol * max(norms(vec))
        nst = pb.solver.nls.status
        nst.n_iter, nst.condition = 0, -1
        try:
            out = pb.solve(state0=vec, save_results=False, verbose=False)
            new = out.get_state(False, force=True).copy()
            for key, val in nst.time_stats.items():
                nls_time[key] = nls_time.get(key, 0.0) + val
        except (ValueError, RuntimeError) as err:
            output(f"peer: increment to {p_new:.4g} kPa raised {err!r}")
            new = vec
        total_its += int(nst.n_iter)
        if verbose:
            print(f"  SfePy {p_new:.4g} kPa: {'converged' if nst.condition == 0 else 'FAILED'} "
                  f"after {nst.n_iter} iterations, {time.perf_counter() - t_solve:.0f} s",
                  file=sys.stderr, flush=True)
        if nst.condition == 0:
            iterations.append(int(nst.n_iter))
            vec, p_done, cuts = new, p_new, 0
            queue.pop(0)
            continue
        output(f"peer: increment to {p_new:.4g} kPa failed (condition {nst.condition}); "
               "halving it")
        cuts += 1
        total_cuts += 1
        if cuts > max_cuts:
            ok = False
            break
        queue.insert(0, 0.5 * (p_done + p_new))
    solve_s = time.perf_counter() - t_solve
    output.set_output(quiet=False)

    pb.equations.variables.set_state(vec, False, force=True)
    uvals = pb.get_variables()["u"]().reshape(-1, 3)
    tip = np.asarray(mesh.tip_mm, float)
    disp = field.evaluate_at(tip[None, :], uvals).reshape(3)
    log = "\n".join(buffer.getvalue().splitlines()[-_LOG_TAIL:])
    return {"ok": ok, "pressure_kpa": p_done, "tip_mm": tuple(float(x) for x in tip + disp),
            "tip_displacement_mm": float(np.linalg.norm(disp)), "dofs": dofs,
            "order": order, "increments": len(iterations), "cuts": total_cuts,
            "newton_iterations": iterations, "factorizations": total_its,
            "time_s": setup_s + solve_s, "setup_s": setup_s, "solve_s": solve_s,
            "nls_time_s": nls_time, "log": log}


class _IncrementLog(logging.Handler):
    """Collects the pressures at which pnmold's continuation converged an increment."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.pressures: list[float] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.msg.startswith("%s %.4g %s converged in") and record.args[0] == "pressure":
            self.pressures.append(float(record.args[1]))


def solve_with_pnmold(mesh, material, pressure_kpa: float, *, rtol: float) -> dict:
    """pnmold's solve of the same problem (no membrane, no gravity), with its increments."""
    from pnmold.fem import Model, NewtonOptions, SolveOptions, solve_bending
    from pnmold.fem.model import Load

    fixed = {"clamp": (0, 1, 2), **({"symmetry": (1,)} if mesh.half else {})}
    warm = Model(mesh, material, None, fixed)  # compile/load the numba kernels untimed
    warm.evaluate(np.zeros(warm.ndof), Load(pressure_mpa=1e-3), want_k=True)
    logger = logging.getLogger("pnmold.fem.newton")
    handler, level = _IncrementLog(), logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.DEBUG)
    try:
        t0 = time.perf_counter()
        sol = solve_bending(mesh, material, None, pressures_kpa=[pressure_kpa],
                            options=SolveOptions(newton=NewtonOptions(rtol=rtol)))
        wall = time.perf_counter() - t0
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
    last, st = sol.steps[-1], sol.stats
    its = st["newton_iterations"]
    return {"ok": True, "pressure_kpa": last.pressure_kpa, "dofs": st["unknowns"],
            "tip_mm": (last.tip_x_mm, 0.0, last.tip_z_mm), "increments": st["increments"],
            "increments_kpa": handler.pressures, "cuts": st["cuts"], "newton_iterations": its,
            "factorizations": st["factorizations"], "time_s": wall,
            "bend_angle_deg": last.bend_angle_deg}


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pressure", type=float, default=5.0, help="kPa (default 5)")
    parser.add_argument("--wall", type=float, default=2.5, help="MeshSize.wall_mm (2.5)")
    parser.add_argument("--max", type=float, default=5.0, help="MeshSize.max_mm (5.0)")
    parser.add_argument("--bulk-ratio", type=float, default=200.0, help="K/mu (200)")
    parser.add_argument("--rtol", type=float, default=1e-7, help="Newton rtol (1e-7)")
    parser.add_argument("--order", type=int, default=2, help="SfePy's order (2)")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from pnmold.design import load_design
    from pnmold.pipeline import build

    design = load_design("fpn")
    with tempfile.TemporaryDirectory() as tmp:
        build(design, Path(tmp), fem=False, use_slicer=False)
        compare(design, Path(tmp) / "actuator.step", pressure_kpa=args.pressure,
                size=(args.wall, args.max), bulk_ratio=args.bulk_ratio, rtol=args.rtol,
                order=args.order)


def compare(design, step, *, pressure_kpa: float = 5.0, size: tuple[float, float] = (2.5, 5.0),
            bulk_ratio: float = 200.0, rtol: float = 1e-7, order: int = 2) -> tuple[dict, dict]:
    """Mesh ``step`` (``MeshSize(*size)``), solve with pnmold and SfePy, print the comparison.

    The material is the supplement's Elastosil M4601 (Yeoh C10 0.11, C20 0.02, C30 0 MPa)
    with the pointwise penalty K = ``bulk_ratio`` mu on both sides; no membrane, no gravity.
    """
    from pnmold.fem import Yeoh
    from pnmold.mesh import mesh_actuator
    from pnmold.tetmesh import MeshSize

    mesh, _ = mesh_actuator(Path(step), design, MeshSize(*size))
    print(f"peer check: fPN {'half ' if mesh.half else ''}model, MeshSize{tuple(size)}: "
          f"{mesh.n_nodes} nodes, {mesh.n_tets} tets")
    material = Yeoh(0.11, 0.02, 0.0, bulk_ratio=bulk_ratio, volumetric="penalty")
    return compare_on_mesh(mesh, material, pressure_kpa, rtol=rtol, order=order)


def compare_on_mesh(mesh, material, pressure_kpa: float, *, rtol: float,
                    order: int = 2) -> tuple[dict, dict]:
    """Solve with pnmold, then with SfePy on pnmold's increments; print the comparison."""
    print(f"Yeoh C10 {material.c10_mpa:g}, C20 {material.c20_mpa:g}, C30 {material.c30_mpa:g} MPa, "
          f"pointwise penalty K = {material.bulk_ratio:g} mu; no membrane, no gravity; "
          f"{pressure_kpa:g} kPa; rtol {rtol:g}")
    ours = solve_with_pnmold(mesh, material, pressure_kpa, rtol=rtol)
    peer = solve_with_sfepy(mesh, material, pressure_kpa, rtol=rtol, order=order,
                            increments_kpa=ours["increments_kpa"], verbose=True)
    rows = (("", "pnmold (P2)", f"SfePy (P{order})"),
            ("DOFs (free)", ours["dofs"], peer["dofs"]),
            ("increments", ours["increments"], peer["increments"]),
            ("failed increments (cuts)", ours["cuts"], peer["cuts"]),
            ("Newton its (converged)", sum(ours["newton_iterations"]),
             sum(peer["newton_iterations"])),
            ("factorisations (all)", ours["factorizations"], peer["factorizations"]),
            ("time s", f"{ours['time_s']:.1f}", f"{peer['time_s']:.1f}"),
            ("tip x, z mm", "{:.3f}, {:.3f}".format(*ours["tip_mm"][::2]),
             "{:.3f}, {:.3f}".format(*peer["tip_mm"][::2])))
    for row in rows:
        print(f"{row[0]:<26}{row[1]!s:>22}{row[2]!s:>22}")
    print(f"pnmold increments (kPa): {', '.join(f'{p:.4g}' for p in ours['increments_kpa'])}")
    print(f"SfePy Newton its per increment: {peer['newton_iterations']}; its time split "
          + ", ".join(f"{k} {v:.1f} s" for k, v in peer["nls_time_s"].items()))
    if not peer["ok"]:
        print(f"SfePy FAILED at {peer['pressure_kpa']:.4g} kPa; its last output:")
        print(peer["log"])
        return ours, peer
    tip0 = np.asarray(mesh.tip_mm, float)
    diff = float(np.linalg.norm(np.subtract(ours["tip_mm"], peer["tip_mm"])))
    disp = float(np.linalg.norm(np.subtract(ours["tip_mm"], tip0)))
    print(f"time ratio SfePy / pnmold: {peer['time_s'] / ours['time_s']:.2f}")
    print(f"tip difference: {diff:.2e} mm = {100 * diff / disp:.3f}% of the tip displacement "
          f"({disp:.2f} mm, bend {ours['bend_angle_deg']:.1f} deg)")
    return ours, peer


if __name__ == "__main__":
    main()
