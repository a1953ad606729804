"""The body's roll about its length when it is held on its side (orientation ``horizontal``).

Held with its bending plane horizontal, the weight of the chambers, which stand above the slab that
joins them, twists the body about its length: the chambers sink toward the ground. The FE of the whole
body shows the roll gathered in the gaps between the chambers, while each chamber turns as a rigid
closed cell. A hinge rolled by ``phi`` has the share ``sin(phi)`` of the weight along the chambers'
direction (+z of its own bending plane), and the body sags in its bending plane as if hanging chambers
down, a little; the share ``cos(phi)`` twists it further.

The reduced model carries it as a twist of the rod's edges. The weight distal to node ``r_j`` (the
proximal node of edge ``j``) has the moment about the twist axis, per g and before any roll::

    L_j = sum_(e >= j) w_e ((q_e - r_j) . n_j - a)

Here ``w_e`` is edge ``e``'s weight per g, ``q_e`` its load point (:class:`pnmold.physics.rod.RodLoads`)
and ``n_j = (sin psi_j, cos psi_j)`` the edge's normal toward the chambers in the bending plane. The
twist axis lies ``a`` above the bottom face (:func:`roll_axis_mm`: the paper's plane). Rolled by
``phi``, the torque is ``g L_j cos(phi)``, and along edge ``j`` of torsional compliance ``c_j`` (rad
per N mm) the roll grows as ``d phi = c_j g L_j cos(phi)``, whose solution over the edge is
:func:`sweep`'s: however compliant, the roll tends to a quarter turn and never passes it. Hinge ``j``
bends under the weight's chambers-down moment times ``sin(phi_j)`` (the rod's hinge shares,
:func:`pnmold.physics.rod.solve_rod`) through the chambers-down compliance. For a shape the roll is
explicit; shape and roll are iterated to a fixed point (:func:`rolled`). The distal body's roll relative
to a hinge is left out of its moment and torque (its in-plane offsets stay in the hinge's plane).

Why each hinge's own frame: with the share taken at each load's roll instead, the reduced model sagged
the random design above twice as far as the FE at rest (tip 60.7 mm up against 29.9 mm): the hinges near
the clamp, which carry the longest lever, roll least. Why the paper's plane: with the axis in the
middle of the slab the model's roll reversed by 9.6 kPa on that design (-2.5 deg at the tip) where the
FE's stayed +9.3 deg; an inextensible sheet twisted about an axis off its own plane would have to
stretch, so the sheet holds the axis (10.0 deg then).

The compliance comes from an FE probe, not from St-Venant's torsion of the sections
(:func:`pnmold.physics.probes.roll_probe`): the whole body held on its side at 1 g, at rest. On a random
10-chamber Elastosil design the roll per gap was 3-6x what the St-Venant torsion of the gap's slab (width
x slab and floor) predicts. The FE's sections roll as rigid cells between the gaps, so the extra
compliance lies where the gap's slab meets the chambers. :func:`identify_roll` reads it from the probe's
section rolls with this module's own torque and sweep, so the model reproduces the probe's roll at rest.

Under pressure the body unrolls faster than the curl of its bend alone explains: on that design the FE's tip
roll fell 29.1, 22.5, 15.7 and 8.5 deg at 0, 3.2, 6.4 and 9.6 kPa, nearly in proportion to the pressure, where
the model with the compliance of rest gave 29.2, 24.7, 18.8 and 10.3, and its tip lay 5.3, 8.1 and 6.7 mm from
the FE's. The torsional stiffness changes with the pressure (likely the walls' tension under pressure resisting
the twist, as an axial pull stiffens a twisted bar: not shown). The model reads it from the same probe carried
on through the range (:data:`ROLL_PROBE_SHARES` of the free run's last pressure): at each pressed state, the
factor on the torsional stiffness that brings the model's tip nearest the FE's
(:func:`pnmold.physics.probes.roll_stiffening`), linear in the effective pressure between them and held beyond
the last (:func:`stiffened`;
the batch's stiffness factor divides the pressure as it multiplies the stiffness; never read past what the FE
solved). Read from the tips, the factor also carries what else of the rolled sag the model leaves out.

Why a factor per state, not one law: a single stiffening linear in pressure, ``c / (1 + beta p)``, read up
to a tenth of the free run's last pressure (2.4, 4.8, 7.3 kPa on that design: 0.045 per kPa) brought the
FE's tips on the build's finer mesh at 3.2, 6.4 and 9.6 kPa within 1.0, 0.6 and 3.2 mm, but on the fPN
(-0.018 per kPa read at 1.5-4.6 kPa, a softening) it halved the stiffness by 26 kPa: the model rolled the
body 38 deg there, where the FE's sections rolled 9 deg at most mid-length and 13 at the tip (the curled
body's weight twists it back), and bent 194 deg against the FE's 211. Read on to a quarter of the range
instead, the one law came out negative on that design (-0.025 per kPa) and the tips 9-19 mm off: one law
cannot follow both ends. Away from the states read
(under another weight or rubber) it is a prediction; at 0.8 g, not read, the FE's rest roll at the tip was
19.9 deg and the model's 19.7 (no softening toward a buckling of the roll there).

Read by a camera looking along gravity, the tip's z is the bending plane's, turned by each edge's roll:
``z = sum_e -l_e sin(psi_e) cos(phi_e)``, and x is unchanged. The bend angle is the end's direction
projected on the x-z plane (:func:`world`).

Assumed: the stiffening is linear in pressure; the weight's component out of the rolled bending plane
(``cos phi``) bends the body sideways by nothing (the body is far stiffer across its width, where the paper
lies in its own plane), and the twist axis stays in the paper's plane (without paper, the middle of the slab
that joins the chambers).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pnmold.design import Design
from pnmold.errors import RodError
from pnmold.physics.rod import RodLoads, RodState

#: the probe's gravity (g, horizontal): a test's own load (as the chambers-down probe's)
ROLL_PROBE_G = 1.0
#: the probe's pressed states, as shares of the free run's last pressure, where the torsional stiffening with
#: pressure is read (assumed: dense low in the range, where the rolled weight matters most, on to 0.85 of
#: it, short of where the free run ends)
ROLL_PROBE_SHARES = (1 / 30, 2 / 30, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.85)
#: the factor on the torsional stiffness read at a pressed state lies within these (assumed: between 0.5x and 5x
#: the stiffness at rest)
ROLL_STIFFENING_BOUNDS = (0.5, 5.0)
#: a factor away from 1 costs, in reading it, as a tip miss of this share of the length per e-fold (assumed: where
#: the tip hardly feels the roll, the model's other misfit of a few tenths of a millimetre reads no stiffening)
ROLL_STIFFENING_COST_SHARE = 0.005
#: the stiffening table of a body read with none (it hardly rolls, or no pressed state was reached)
NO_STIFFENING = {"pressure_kpa": (), "factor": ()}
#: the fixed point between shape and roll: at most this many iterations to this change of roll (rad). More
#: roll sags the body toward its chambers, which lengthens the weight's lever and rolls it more: from no roll
#: the iteration climbs to the nearest equilibrium (24 iterations on a 10-chamber Elastosil fPN held
#: horizontal over its ramp, 146 ms for 20 rows against 181 ms chambers up)
_ITERATIONS, _TOL_RAD = 150, 1e-6


def roll_axis_mm(design: Design) -> float:
    """Height of the twist axis above the bottom face (mm): the paper sheet's plane where there is one (an
    inextensible sheet twisted about an axis off its plane would have to stretch), else the middle of the
    slab that joins the chambers (the bottom layer and the fPN's floor under the gaps; with a passive side,
    the body's mid-plane)."""
    if design.paper.present:
        return float(design.sheet_z_mm + design.paper.thickness_mm / 2.0)
    if design.passive_side.present:
        return float(design.mid_plane_z_mm)
    top = design.top_z0_mm + (design.top_layer.floor_mm if design.kind == "fpn" else 0.0)
    return float((design.bottom_z0_mm + top) / 2.0)


def lever(nodes: np.ndarray, angle: np.ndarray, loads: RodLoads, axis_mm: float) -> np.ndarray:
    """(R, K) the moment (N mm per g) of the weight distal to each edge's proximal node about the twist
    axis in the bending plane: ``sum_(e >= j) w_e ((q_e - r_j) . n_j - a)`` (see the module docstring)."""
    sin, cos = np.sin(angle), np.cos(angle)
    r0, r1 = nodes[:, :-1], nodes[:, 1:]
    qx = r0[..., 0] + loads.frac * (r1[..., 0] - r0[..., 0]) + loads.height_mm * sin
    qz = r0[..., 1] + loads.frac * (r1[..., 1] - r0[..., 1]) + loads.height_mm * cos
    f = np.broadcast_to(loads.weight_n, angle.shape)

    def distal(a: np.ndarray) -> np.ndarray:
        return np.cumsum(a[:, ::-1], axis=1)[:, ::-1]

    s_f, s_x, s_z = distal(f), distal(f * qx), distal(f * qz)
    return sin * s_x + cos * s_z - (r0[..., 0] * sin + r0[..., 1] * cos + axis_mm) * s_f


def sweep(compliance: np.ndarray, torque_n_mm: np.ndarray) -> np.ndarray:
    """(R, K+1) the nodes' roll from the clamp out. Along edge j the roll grows as its compliance takes the
    torque ``T_j`` (R, K, at no roll) turned by the cosine of the roll there, d phi = c_j T_j cos(phi) ds /
    l_j, whose solution over the edge is ``phi_(j+1) = gd(c_j T_j + gd^-1(phi_j))`` with the Gudermannian
    ``gd(u) = atan(sinh(u))``: however compliant, a roll tends to a quarter turn and never passes it."""
    rows, k = compliance.shape
    u = np.concatenate([np.zeros((rows, 1)), np.cumsum(compliance * torque_n_mm, axis=1)], axis=1)
    return np.arctan(np.sinh(np.clip(u, -700.0, 700.0)))


def rolled(solve: Callable[[np.ndarray, RodState | None], RodState], compliance: np.ndarray, loads: RodLoads,
           g: float, axis_mm: float, partial: bool = False) -> RodState:
    """The rod's equilibrium with its roll: ``solve(share (R, K), last)`` solves the rod under the
    chambers-down weight ``g`` with each hinge feeling ``share`` of its moment, from the ``last`` state
    (None: from the free shape; :func:`pnmold.physics.rod.solve_rod`); ``compliance`` (R, K) the edges'
    torsional compliance. For a shape the roll is :func:`sweep`'s; shape and roll are iterated to a fixed
    point. A row whose roll does not settle has no equilibrium: :class:`RodError`, or with ``partial`` the
    row comes back NaN, as do the rows the solver left NaN (the last row, the unloaded reference, must have
    one)."""
    rows, k = compliance.shape
    node_roll = np.zeros((rows, k + 1))
    state = solve(np.zeros((rows, k)), None)
    for _ in range(_ITERATIONS):
        target = sweep(compliance, g * lever(state.nodes_mm, state.angle_rad, loads, axis_mm))
        step = np.nan_to_num(target - node_roll)
        node_roll = np.nan_to_num(target)
        state = solve(np.sin(node_roll[:, :-1]), state)
        if np.abs(step).max() < _TOL_RAD:
            break
    else:
        unsettled = np.abs(step).max(axis=1) >= _TOL_RAD
        if not partial or unsettled[-1]:
            raise RodError(np.flatnonzero(unsettled))
        node_roll[unsettled] = np.nan
    lost = np.isnan(state.angle_rad).any(axis=1) | np.isnan(node_roll).any(axis=1)

    def cut(a: np.ndarray) -> np.ndarray:
        a = a.astype(float, copy=True)
        a[lost] = np.nan
        return a

    return RodState(cut(state.angle_rad), cut(state.nodes_mm), cut(state.moment_n_mm), cut(state.force_n),
                    state.iterations, cut(node_roll))


def stiffened(compliance: np.ndarray, p_eff_kpa: np.ndarray, table: dict | None) -> np.ndarray:
    """(R, K) the torsional compliance (K,) at each row's effective pressure (R,) over the stiffening ``table``'s
    factor there (``pressure_kpa``, ``factor``: the module docstring's stiffening under pressure, 1 at rest,
    linear between, held beyond the last pressure; None or empty: none)."""
    p = np.maximum(np.asarray(p_eff_kpa, float), 0.0)
    factor = np.ones_like(p)
    if table and len(table["pressure_kpa"]):
        factor = np.interp(p, [0.0, *table["pressure_kpa"]], [1.0, *table["factor"]])
    return np.asarray(compliance, float)[None, :] / factor[:, None]


def edge_rolls(node_roll: np.ndarray) -> np.ndarray:
    """(R, K) each edge's roll: the mean of its nodes'."""
    return (node_roll[:, :-1] + node_roll[:, 1:]) / 2.0


def world(nodes: np.ndarray, end_rad: np.ndarray, node_roll: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rolled rod's nodes (R, K+1, 2) in the camera's x-z plane, and its end's angle ``end_rad`` (R,) in
    the bending plane projected there, unwrapped as the bending plane's."""
    dz = np.diff(nodes[..., 1], axis=1) * np.cos(edge_rolls(node_roll))
    out = nodes.copy()
    out[:, 1:, 1] = np.cumsum(dz, axis=1)
    last, phi = end_rad, node_roll[:, -1]
    seen = np.arctan2(np.sin(last) * np.cos(phi), np.cos(last))
    return out, last + (seen - last + np.pi) % (2 * np.pi) - np.pi


def identify_roll(design: Design, loads: RodLoads, node_roll: np.ndarray, solve: Callable[[np.ndarray], RodState],
                  g: float) -> np.ndarray:
    """(K,) the edges' torsional compliance (rad per N mm) from an FE probe's section rolls ``node_roll``
    (K+1,) at ``g``: the rod solved under the probe's rolled weight (``solve(share (1, K))``, as in
    :func:`rolled`), each edge's twist over its torque (:func:`sweep` inverted).
    An edge whose torque is under a tenth of the largest (near the tip) is read at a tenth: its twist hardly
    counts there."""
    state = solve(np.sin(node_roll[None, :-1]))
    t = g * lever(state.nodes_mm, state.angle_rad, loads, roll_axis_mm(design))[0]
    twist = np.maximum(np.diff(np.arcsinh(np.tan(np.clip(node_roll, -1.5, 1.5)))), 0.0)  # gd^-1: see sweep
    return twist / np.maximum(t, 0.1 * max(float(t.max()), 1e-12))


def section_rolls(nodes_mm: np.ndarray, displacement_mm: np.ndarray, x_mm: np.ndarray) -> np.ndarray:
    """(K+1,) the roll about +x (rad, positive sinks the chambers toward -y) of the body's sections at ``x_mm``
    from an FE state: the least-squares rotation in the y-z plane of the mesh nodes within a band around
    each x (0.4 of the closest spacing, at most 1 mm); 0 at the clamped end (x = 0)."""
    x = np.asarray(x_mm, float)
    band = min(1.0, 0.4 * float(np.min(np.diff(x))))
    out = np.zeros(x.size)
    for i, xi in enumerate(x):
        near = np.abs(nodes_mm[:, 0] - xi) <= band
        if xi <= 0.0 or near.sum() < 4:
            continue
        ref = nodes_mm[near][:, 1:] - nodes_mm[near][:, 1:].mean(axis=0)
        cur = nodes_mm[near][:, 1:] + displacement_mm[near][:, 1:]
        cur = cur - cur.mean(axis=0)
        # rotation about +x: y -> y cos - z sin, z -> y sin + z cos; positive sinks +z toward -y
        out[i] = np.arctan2(np.sum(ref[:, 0] * cur[:, 1] - ref[:, 1] * cur[:, 0]),
                            np.sum(ref[:, 0] * cur[:, 0] + ref[:, 1] * cur[:, 1]))
    return out
