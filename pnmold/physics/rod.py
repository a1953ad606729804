"""The planar rod of the reduced model: the bottom face as a chain of hinged edges.

The bottom face's line at y = 0 (the paper side, docs/frame-and-units.md) is a polyline of
``K`` edges from the clamped end (node 0 at x = 0) to the tip (node K at x = L). Edge
``e`` makes the angle ``psi_e`` with +x, positive as it turns toward -z (so its
direction is ``(cos psi, -sin psi)`` in x-z); its length is ``l_e``. The hinge at node
``k`` is the proximal end of edge ``k``; its rotation is ``psi_k - psi_(k-1)``.

Loads: the weight of the body over each edge (``weight_n`` per g, at ``frac`` of the edge
and ``height`` above it, both turning with the edge), each hinge feeling the share ``s_k`` of its
moment (1, or per row and hinge: a body rolled about its length has only ``sin(roll)`` of its weight
in each hinge's own bending plane, :mod:`pnmold.physics.roll`), and a vertical force ``F`` at the
tip from a rigid plane under it (blocked force). Equilibrium per hinge::

    eta_k = C_k M_k(psi),   psi = psi_free + cumsum(eta)

with ``C_k`` the hinge compliance (rad per N mm) and ``M_k`` the moment about +y of the
loads distal to node k. Newton's method on all rows at once; the Jacobian is exact:
dM_k/deta_j = -s_k D_max(j,k), D_k = sum_(e >= k) (q_e - r_k) . f_e (a rotation at node j
turns every load distal to it about r_j), with the tip force's part unshared (see :func:`moments`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from pnmold.errors import RodError

_TOL_RAD = 1e-11
#: Newton iterations of one attempt from the free shape; a row past a limit point never converges,
#: and it is the failures that cost: after these the row goes to the fallbacks of ``_equilibrium``
#: (the weight ramped, then the previous row's state). 30 instead of 12 gave the same equilibria
#: on 270 runs of the blind benchmark's gravity and null cases (0.5-1.5 g, modulus 0.8-1.2) and
#: took 1.5x longer
_MAX_ITERATIONS = 12
_MAX_STEP_RAD = 0.5
_MAX_HALVINGS = 6
#: an equilibrium whose tip turns this much more (or less) than its free shape does, from the row before
#: it along the ramp, left the ramp's branch (assumed: a ramp's steps turn the loaded tip about as much as
#: the free one; the fig-s2a-h5 hanging chambers down jumped 220 deg between 32 and 38 kPa)
_BRANCH_JUMP_RAD = np.radians(45.0)


@dataclass(frozen=True, eq=False)
class RodLoads:
    """Per edge (K,): weight per g (N), load point as fraction along the edge and height above it (mm)."""

    weight_n: np.ndarray
    frac: np.ndarray
    height_mm: np.ndarray


@dataclass(frozen=True, eq=False)
class RodState:
    """Solved rows: edge angles (R, K), nodes (R, K+1, 2) in (x, z), moments (R, K), tip force (R,); held on
    its side, the nodes' roll about the length (R, K+1; :mod:`pnmold.physics.roll`), else None."""

    angle_rad: np.ndarray
    nodes_mm: np.ndarray
    moment_n_mm: np.ndarray
    force_n: np.ndarray
    iterations: int
    roll_rad: np.ndarray | None = None


def node_positions(angle: np.ndarray, length: np.ndarray) -> np.ndarray:
    """(R, K+1, 2) positions of the nodes, node 0 at the origin."""
    angle = np.ascontiguousarray(angle, float)
    return _node_positions(angle, np.ascontiguousarray(np.broadcast_to(length, angle.shape), float))


@nb.njit(cache=True)
def _node_positions(angle, length):  # pragma: no cover (compiled)
    rows, k_edges = angle.shape
    out = np.zeros((rows, k_edges + 1, 2))
    for r in range(rows):
        x = z = 0.0
        for k in range(k_edges):
            x += length[r, k] * np.cos(angle[r, k])
            z += -length[r, k] * np.sin(angle[r, k])
            out[r, k + 1, 0] = x
            out[r, k + 1, 1] = z
    return out


def hinge_shares(share: np.ndarray | float | None, shape: tuple[int, int]) -> np.ndarray:
    """The share of the weight's moment each hinge feels, (R, K) (None: all of it)."""
    return np.ascontiguousarray(np.broadcast_to(np.asarray(1.0 if share is None else share, float), shape))


def moments(nodes: np.ndarray, angle: np.ndarray, loads: RodLoads, gravity_xz: tuple[float, float],
            force: np.ndarray, share: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Moment about +y at the proximal node of each edge (N mm) and D (see module docstring);
    ``share`` (R, K): the share of the weight's moment each hinge feels (default all). D is the loads'
    whole (each hinge's share left out): a rotation at node j changes hinge k's moment by its share of
    D_max(j,k), so Newton's matrix is (I + diag(C s) A) (exact without a tip force; with one and shares
    below 1, the blocked tip held horizontal, the tip force's part is scaled too: Newton then converges
    linearly)."""
    f64 = np.ascontiguousarray
    return _moments(f64(nodes, float), f64(angle, float), f64(loads.weight_n, float), f64(loads.frac, float),
                    f64(loads.height_mm, float), float(gravity_xz[0]), float(gravity_xz[1]),
                    hinge_shares(share, angle.shape), f64(force, float))


@nb.njit(cache=True)
def _moments(nodes, angle, weight, frac, height, gx, gz, share, force):  # pragma: no cover (compiled)
    """Compiled :func:`moments`: the loads distal to each node summed from the tip inward."""
    rows, k_edges = angle.shape
    m = np.empty((rows, k_edges))
    d = np.empty((rows, k_edges))
    for r in range(rows):
        tip_x, tip_z = nodes[r, k_edges, 0], nodes[r, k_edges, 1]
        sfx = sfz = sqf = sqd = 0.0
        for k in range(k_edges - 1, -1, -1):
            r0x, r0z = nodes[r, k, 0], nodes[r, k, 1]
            qx = r0x + frac[k] * (nodes[r, k + 1, 0] - r0x) + height[k] * np.sin(angle[r, k])
            qz = r0z + frac[k] * (nodes[r, k + 1, 1] - r0z) + height[k] * np.cos(angle[r, k])
            fx, fz = weight[k] * gx, weight[k] * gz
            sfx += fx
            sfz += fz
            sqf += qz * fx - qx * fz
            sqd += qx * fx + qz * fz
            m[r, k] = share[r, k] * (sqf - (r0z * sfx - r0x * sfz)) - (tip_x - r0x) * force[r]
            d[r, k] = sqd - (r0x * sfx + r0z * sfz) + (tip_z - r0z) * force[r]
    return m, d


def solve_rod(angle_free: np.ndarray, length: np.ndarray, compliance: np.ndarray, loads: RodLoads,
              gravity_xz: tuple[float, float], plane_z_mm: float | None = None, start: np.ndarray | None = None,
              share: np.ndarray | None = None) -> RodState:
    """Equilibrium of every row; with ``plane_z_mm``, the tip may not go below that plane.
    ``gravity_xz``: ``(gx, gz)`` in g; ``start``: the hinges' rotations (R, K) to start Newton from
    (default: the free shape); ``share``: the share of the weight's moment each hinge feels (R, K).

    Rows that repeat (a cycled ramp returns to the same pressures) are solved once, in the order
    they first appear (a failing row continues from the one before it, as a ramp does)."""
    g, gxz = hinge_shares(share, angle_free.shape), gravity_xz
    eta0 = np.zeros(angle_free.shape) if start is None else np.asarray(start, float)
    loaded = bool(np.any(gxz)) and bool(np.any(loads.weight_n)) and bool(np.any(g))
    if not loaded and plane_z_mm is None:  # nothing to solve: the free shape
        return _solve_rows(angle_free, length, compliance, loads, gxz, g, plane_z_mm, eta0)
    order, at = _distinct_rows(np.concatenate([angle_free, length, compliance, g], axis=1))
    try:
        one = _solve_rows(angle_free[order], length[order], compliance[order], loads, gxz, g[order], plane_z_mm,
                          eta0[order])
    except RodError as err:
        raise RodError(np.flatnonzero(np.isin(at, err.rows))) from None
    return RodState(one.angle_rad[at], one.nodes_mm[at], one.moment_n_mm[at], one.force_n[at], one.iterations)


def _distinct_rows(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The first row of each distinct row of ``a`` (R, n), in the order they appear, and each row's place
    among them (by their bytes: ``np.unique(axis=0)`` took a quarter of a horizontal diagnosis)."""
    a = np.ascontiguousarray(a)
    seen: dict[bytes, int] = {}
    at = np.array([seen.setdefault(row.tobytes(), len(seen)) for row in a], dtype=np.int64)
    return np.unique(at, return_index=True)[1], at


def _solve_rows(angle_free: np.ndarray, length: np.ndarray, compliance: np.ndarray, loads: RodLoads,
                gxz: tuple[float, float], g: np.ndarray, plane_z_mm: float | None, eta0: np.ndarray) -> RodState:
    """:func:`solve_rod` on these rows as they are (``g``: the hinges' shares of the weight)."""
    rows, k = angle_free.shape
    eta = eta0.copy()
    force = np.zeros(rows)
    loaded = bool(np.any(gxz)) and bool(np.any(loads.weight_n)) and bool(np.any(g))
    contact = np.zeros(rows, bool)
    if plane_z_mm is not None:
        free = node_positions(angle_free, length)[:, -1, 1]
        contact = free < plane_z_mm + 1e-12 if not loaded else np.ones(rows, bool)
    if not loaded and not contact.any():
        nodes = node_positions(angle_free, length)
        return RodState(angle_free, nodes, np.zeros((rows, k)), force, 0)
    its = 0
    # blocked rows start straight: the blocked shape is near the rest state, far from the free curl
    eta[contact] = -np.diff(angle_free[contact], axis=1, prepend=0.0)
    for _ in range(3):  # active set of the contact rows
        eta, force, its, ok = _equilibrium(angle_free, length, compliance, loads, gxz, g, plane_z_mm, contact,
                                           eta, force)
        if not ok.all():
            raise RodError(np.flatnonzero(~ok))
        if plane_z_mm is None:
            _follow_branch(angle_free, length, compliance, loads, gxz, g, contact, eta, force)
        release = contact & (force < 0)
        if plane_z_mm is not None:
            tip_z = node_positions(angle_free + np.cumsum(eta, axis=1), length)[:, -1, 1]
            engage = ~contact & (tip_z < plane_z_mm - 1e-9)
        else:
            engage = np.zeros(rows, bool)
        if not (release.any() or engage.any()):
            break
        contact = (contact & ~release) | engage
        force[~contact] = 0.0
    angle = angle_free + np.cumsum(eta, axis=1)
    nodes = node_positions(angle, length)
    m, _ = moments(nodes, angle, loads, gxz if loaded else (0.0, 0.0), force, g)
    return RodState(angle, nodes, m, force, its)


def _equilibrium(angle_free, length, compliance, loads, gxz, g, plane_z_mm, contact, eta0, force0):
    """Newton on every row; rows that fail are retried with the weight ramped in four stages, then
    from the previous row's equilibrium (the branch a pressure ramp follows past a limit point)."""
    args = (angle_free, length, compliance)
    eta, force, its, ok = _newton(*args, loads, gxz, g, plane_z_mm, contact, eta0, force0)
    if ok.all():
        return eta, force, its, ok
    bad = ~ok
    sub = tuple(a[bad] for a in (angle_free, length, compliance))
    e, f = eta0[bad], force0[bad]
    for frac in (0.25, 0.5, 0.75, 1.0):
        e, f, _, good = _newton(*sub, loads, gxz, g[bad] * frac, plane_z_mm, contact[bad], e, f)
    eta[bad], force[bad], ok[bad] = e, f, good
    for i in np.flatnonzero(~ok):
        if i == 0 or not ok[i - 1]:
            continue
        one = slice(i, i + 1)
        e, f, _, good = _newton(*(a[one] for a in args), loads, gxz, g[one], plane_z_mm, contact[one],
                                eta[i - 1:i].copy(), force[i - 1:i].copy())
        if good[0]:
            eta[i], force[i], ok[i] = e[0], f[0], True
    return eta, force, its, ok


def _follow_branch(angle_free, length, compliance, loads, gxz, g, contact, eta, force) -> None:
    """In place: the rows in the order of their free tip angle (a pressure ramp's), each solved from rest
    alone may have landed on another branch than the one the ramp follows (under an opposing weight a
    curled rod has a second equilibrium, turned over). A row that left the branch of the row before it
    (:data:`_BRANCH_JUMP_RAD`) is solved again from that row's equilibrium, as the actuator (and the FE's
    path) goes; where the branch has no equilibrium there (past its limit point: the actuator snaps), the
    other branch's state stays, and the ramp goes on from it."""
    free_tip = angle_free[:, -1]
    order = np.argsort(free_tip, kind="stable")
    last = order[0]
    for row in order[1:]:
        jump = (eta[row].sum() - eta[last].sum())
        if abs(jump) > _BRANCH_JUMP_RAD:
            one = slice(row, row + 1)
            e, f, _, good = _newton(angle_free[one], length[one], compliance[one], loads, gxz, g[one], None,
                                    contact[one], eta[last:last + 1].copy(), force[last:last + 1].copy())
            if good[0]:
                eta[row], force[row] = e[0], f[0]
        last = row


def structured_solve(compliance: np.ndarray, d: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve (I + diag(C) A) x = rhs, A_kj = D_max(j,k), for (R, K, m) right-hand sides in O(K).

    Row k reads x_k = rhs_k - C_k (D_k S_(k-1) + T_(k-1)) with S the prefix sum of x and
    T_(k-1) = sum_(j >= k) D_j x_j, so (S_k, T_k, 1) = A_k (S_(k-1), T_(k-1), 1): a running
    product of 3x3 matrices from the clamp to the tip, started from (0, tau, 1) with tau set
    by T_(K-1) = 0."""
    f64 = np.ascontiguousarray
    return _structured_solve(f64(compliance, float), f64(d, float), f64(rhs, float))


@nb.njit(cache=True)
def _structured_solve(compliance, d, rhs):  # pragma: no cover (compiled)
    rows, k_edges, n_rhs = rhs.shape
    out = np.empty((rows, k_edges, n_rhs))
    s_tau = np.empty(k_edges)  # dS_k / dtau
    s_0 = np.empty(k_edges)  # S_k at tau = 0
    for r in range(rows):
        for j in range(n_rhs):
            p00, p01, p10, p11, b0, b1 = 1.0, 0.0, 0.0, 1.0, 0.0, 0.0
            for k in range(k_edges):
                c, dk = compliance[r, k], d[r, k]
                cd = c * dk
                a00, a01, a10, a11 = 1.0 - cd, -c, cd * dk, 1.0 + cd
                p00, p01, p10, p11 = a00 * p00 + a01 * p10, a00 * p01 + a01 * p11, a10 * p00 + a11 * p10, \
                    a10 * p01 + a11 * p11
                b0, b1 = a00 * b0 + a01 * b1 + rhs[r, k, j], a10 * b0 + a11 * b1 - dk * rhs[r, k, j]
                s_tau[k], s_0[k] = p01, b0
            tau = -b1 / p11
            last = 0.0
            for k in range(k_edges):
                now = s_tau[k] * tau + s_0[k]
                out[r, k, j] = now - last
                last = now
    return out


def _norm(res, nodes, contact, plane_z_mm):
    """Per row: the hinge residual (rad) and, in contact, the tip's gap (mm per 100 mm of lever)."""
    total = np.sum(res * res, axis=1)
    if plane_z_mm is not None:
        total += np.where(contact, ((nodes[:, -1, 1] - plane_z_mm) / 100.0) ** 2, 0.0)
    return np.sqrt(total)


def _newton(angle_free, length, compliance, loads, gxz, g, plane_z_mm, contact, eta, force):
    """Newton with backtracking on every row; a row leaves the iteration once converged (so rows
    near a limit point do not drag the converged ones through every iteration)."""
    eta, force = eta.copy(), force.copy()
    ok = np.zeros(angle_free.shape[0], bool)
    live = np.arange(angle_free.shape[0])
    stalled = np.zeros(angle_free.shape[0], bool)
    it = 0
    while live.size and it < _MAX_ITERATIONS:
        it += 1
        sub = (angle_free[live], length[live], compliance[live], contact[live])
        e, f, done, worse = _newton_step(*sub, loads, gxz, g[live], plane_z_mm, eta[live], force[live])
        eta[live], force[live], ok[live] = e, f, done
        gave_up = worse & stalled[live]  # every halving failed twice running: past a limit point
        stalled[live] = worse
        live = live[~done & ~gave_up]
    return eta, force, it, ok


def _newton_step(angle_free, length, compliance, contact, loads, gxz, g, plane_z_mm, eta, force):
    """One Newton iteration of these rows: (eta, force, converged, residual still grown after every
    halving); converged rows get the full step."""

    def evaluate(eta, force):
        angle = angle_free + np.cumsum(eta, axis=1)
        nodes = node_positions(angle, length)
        m, d = moments(nodes, angle, loads, gxz, force, g)
        return nodes, d, eta - compliance * m

    nodes, d, res = evaluate(eta, force)
    if contact.any():
        x_rel = nodes[:, -1:, 0] - nodes[:, :-1, 0]  # (R, K): tip x minus node x
        y = structured_solve(compliance * g, d, np.stack([-res, compliance * x_rel], axis=-1))
        gap = nodes[:, -1, 1] - plane_z_mm
        a_y1 = -np.sum(x_rel * y[..., 0], axis=1)
        a_y2 = -np.sum(x_rel * y[..., 1], axis=1)
        d_force = np.where(contact, (a_y1 + gap) / np.where(contact, a_y2, 1.0), 0.0)
        d_eta = y[..., 0] - d_force[:, None] * y[..., 1]
    else:
        d_eta = structured_solve(compliance * g, d, -res[..., None])[..., 0]
        d_force = np.zeros(eta.shape[0])
    big = np.abs(d_eta).max(axis=1, keepdims=True)
    done = big[:, 0] < _TOL_RAD  # False for NaN: a row that blew up never counts as converged
    scale = np.where(done[:, None], 1.0, np.minimum(1.0, _MAX_STEP_RAD / np.maximum(big, 1e-300)))
    norm0 = _norm(res, nodes, contact, plane_z_mm)
    worse = np.zeros(done.shape, bool)
    for _ in range(_MAX_HALVINGS):  # backtrack rows whose residual grew (the weight's lever turns)
        trial = eta + scale * d_eta, force + scale[:, 0] * d_force
        if done.all():
            break
        nodes, d, res = evaluate(*trial)
        worse = (_norm(res, nodes, contact, plane_z_mm) > norm0) & ~done
        if not worse.any():
            break
        scale[worse] /= 2
    return trial[0], trial[1], done, worse
