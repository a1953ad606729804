"""The FE's response to a material or layer effect, as a pressure factor on the free law.

A characterisation's variant run (:data:`pnmold.physics.characterise.VARIANTS`) is the free
bend with one effect on at a reference value. For each of its steps the *equivalent
pressure* q is where the nominal free law reaches the same bend angle (or the same cavity
volume): the variant at pressure p looks like the nominal at q. The reduced model keeps two
factors, one for the shape (bend angle) and one for the volume, so that an effect that
moves the bend and the volume differently (a stretching layer, the "fingerprint" of docs/diagnosis.md)
leaves the FE's own signature; and a stretch of the free part (a compliant layer lengthens
the actuator): the ratio of the tip's distance from the clamp's end to the nominal's at the
bend's q, which the rod applies to every free edge (the bend's shape kept, the tip placed):

- a softening (``layer_compliance``) as ``q/p`` over the applied pressure p: the shape reads
  the free law at ``p (1 + s (q/p - 1))``;
- a stiffening (``strain_stiffening``) as ``p/q`` over the deformation level q: a pressure
  p_m reaches the q solving ``p_m = q (1 + s (p/q - 1))``.

``s`` is the effect's intensity (the layer's lost stiffness share, the added Yeoh slope),
worked out by the effect's term in :mod:`pnmold.physics.rom_effects`. With runs at several values the
factor is piecewise linear in ``s`` through them (and 1 at ``s = 0``), the last piece
extended beyond; linear between is an assumption, checked against FE runs at other values
by ``tests/test_rom.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the curves an equivalent pressure is made from: the shape's and the volume's (the
#: stretch, ``length``, is read at the bend's equivalent pressure)
CURVES = {"bend": "bend_angle_deg", "volume": "cavity_volume_ml"}


@dataclass(frozen=True)
class Factor:
    """A factor tabulated over a pressure (held constant beyond the table's ends)."""

    at_kpa: np.ndarray
    factor: np.ndarray

    def __call__(self, p_kpa: np.ndarray) -> np.ndarray:
        return np.interp(p_kpa, self.at_kpa, self.factor)


@dataclass(frozen=True)
class Response:
    """An effect's factor from runs at ``intensities`` (ascending, > 0): piecewise linear in the
    intensity through 1 at 0 and each run's factor, the last piece extended beyond."""

    intensities: tuple[float, ...]
    tables: tuple[Factor, ...]

    def __call__(self, p_kpa: np.ndarray, intensity: float | np.ndarray) -> np.ndarray:
        p = np.asarray(p_kpa, float)
        s = np.broadcast_to(np.asarray(intensity, float), p.shape)
        nodes = np.concatenate([[0.0], self.intensities])
        values = np.stack([np.ones_like(p), *(f(p) for f in self.tables)])
        j = np.clip(np.searchsorted(nodes, s, side="right") - 1, 0, len(nodes) - 2)
        t = (s - nodes[j]) / (nodes[j + 1] - nodes[j])
        lo = np.take_along_axis(values, j[None], axis=0)[0]
        hi = np.take_along_axis(values, j[None] + 1, axis=0)[0]
        return lo + t * (hi - lo)


def equivalent_pressure(base_p: np.ndarray, base_curve: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """The nominal pressure where ``base_curve`` reaches each value of ``curve`` (nan beyond its range).

    ``base_curve`` must rise with pressure; a flat or falling stretch (a stalled solve)
    is skipped."""
    rising = np.concatenate([[True], np.diff(base_curve) > 0])
    rising &= base_curve >= np.maximum.accumulate(base_curve)
    bp, bc = base_p[rising], base_curve[rising]
    q = np.interp(curve, bc, bp)
    return np.where((curve >= bc[0]) & (curve <= bc[-1]), q, np.nan)


def factor(base: dict[str, np.ndarray], variant: dict[str, np.ndarray], curve: str, softening: bool) -> Factor:
    """One variant run's factor on ``curve`` against the nominal curves: ``bend`` and ``volume``
    the equivalent pressure's (softening: q/p over p; stiffening: p/q over q), ``length`` the
    ratio of the tip's distance from the clamp's end to the nominal's at the bend's equivalent
    pressure (over p, or q; 1 at 0). Steps below 2 % of the variant's largest pressure (both
    curves near their rest values) take the first usable value."""
    p = variant["pressure_kpa"]
    name = CURVES.get(curve, "bend_angle_deg")
    q = equivalent_pressure(base["pressure_kpa"], base[name], variant[name])
    ok = np.isfinite(q) & (p > 0.02 * p.max()) & (q > 0)
    if ok.sum() < 2:
        return Factor(np.array([0.0, 1.0]), np.ones(2))
    p, q = p[ok], q[ok]
    if curve == "length":
        x0, bp = base["clamp_x_mm"], base["pressure_kpa"]
        chord = np.hypot(variant["tip_x_mm"][ok] - x0, variant["tip_z_mm"][ok])
        value = chord / np.hypot(np.interp(q, bp, base["tip_x_mm"]) - x0, np.interp(q, bp, base["tip_z_mm"]))
    else:
        value = q / p if softening else p / q
    at = p if softening else q
    order = np.argsort(at)
    at, value = at[order], value[order]
    if curve == "length":  # unloaded, the layer has nothing to stretch
        at, value = np.concatenate([[0.0], at]), np.concatenate([[1.0], value])
    return Factor(at, value)


def responses(base: dict[str, np.ndarray], runs: list[tuple[float, dict[str, np.ndarray]]],
              softening: bool) -> dict[str, Response]:
    """``{"bend": .., "volume": .., "length": ..}`` Responses from variant runs ``(intensity, curves)``."""
    runs = sorted(runs, key=lambda r: r[0])
    return {curve: Response(tuple(s for s, _ in runs), tuple(factor(base, v, curve, softening) for _, v in runs))
            for curve in (*CURVES, "length")}


def solve_stiffened(p_m: np.ndarray, ratio, points: int = 1025) -> np.ndarray:
    """q with ``q ratio(q) = p_m``: ``q ratio(q)`` tabulated on ``points`` q from 0 to 1.5 x the
    largest p_m and inverted by interpolation (it rises; ``ratio > 2/3``): to about 1e-5 relative."""
    p_m = np.asarray(p_m, float)
    q = np.linspace(0.0, 1.5 * max(float(p_m.max(initial=0.0)), 1e-9), points)
    g = np.maximum.accumulate(q * ratio(q))
    return np.where(p_m > 0, np.interp(p_m, g, q), p_m)
