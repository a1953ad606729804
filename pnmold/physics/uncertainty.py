"""The design's own uncertainty, carried into what a recording can be asked to show.

A design read off another lab's paper knows some dimensions only roughly: Table 1 gives a
segment's outer sizes, and the roof, the ribs and where the constraint sits are inferred from
them. Such a design's misfit to the lab's recording is model-form error, not missing physics
(docs/diagnosis.md: geometry known only to a millimetre must not be treated as if it were signal).
The user states each uncertain dimension's standard uncertainty (``pnmold diagnose --uncertain
chambers.outer_wall_mm=1``); the FE solves the free bend of the design with that dimension moved
up by it (:func:`pnmold.physics.characterise.uncertainty_runs`, cached), and
:class:`DesignFloor` reads what the move changes in each recorded observable, row by row, once
the modulus has absorbed what it can (the diagnosis calibrates a stiffness scale anyway, so only
the change of shape counts). The dimensions are taken as independent: their changes add in
quadrature, and the sum is a floor under the rows' noise (:func:`pnmold.diagnose.data.build_dataset`).

A blocked force at a low pressure hardly depends on the modulus (it is the pressure's moment over
the lever: on the README's worked example a rubber 1.2x stiffer moves the reduced model's force 1 % at
5 kPa, 3 % at 10 kPa), so it is not aligned: with a blocked-force recording each moved design's
blocked tip is solved at the nominal probe's pressure (``uncertainty_runs(blocked=True)``), and the
share it changes the force there is taken at every row, times the row's recorded force (assumed: a
dimension changes the force by about the same share further up). Linear in each dimension (one run at +1 standard
uncertainty); step recordings get no floor (the free run has no flow), said in the diagnosis.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from pnmold.design import SECTIONS, Design, validate
from pnmold.errors import DesignError
from pnmold.physics.characterisation import Characterisation
from pnmold.physics.reading import read_bend, read_tip, read_volume
from pnmold.recording import Recording

#: the modulus ratios over which a moved dimension's curve is aligned with the nominal's (what a
#: recalibrated stiffness scale absorbs); assumed: a dimension moved by its uncertainty changes the
#: stiffness by well under a factor 1.5
ALIGN_RATIOS = np.geomspace(1.0 / 1.5, 1.5, 161)
#: keys of the design-uncertainty runs among a characterisation's variants
UNCERTAIN_PREFIX = "design:"
#: observables the free run's curves give (the others get no floor)
READ = ("bend_angle_deg", "tip_x_mm", "tip_z_mm", "volume_ml")


def check_uncertain(design: Design, uncertain: Mapping[str, float]) -> dict[str, float]:
    """``field -> standard uncertainty``, checked: each a dimension of the design (a number in mm,
    ``section.name_mm``), the uncertainty > 0, and the design moved up by it still valid; else
    :class:`DesignError` naming the field."""
    out = {}
    for field, sd in uncertain.items():
        section, _, name = field.partition(".")
        names = [f.name for f in dataclasses.fields(SECTIONS[section])] if section in SECTIONS else []
        if name not in names or not name.endswith("_mm"):
            raise DesignError(field, "an uncertain dimension must be a design field in mm (section.name_mm), "
                              f"e.g. chambers.outer_wall_mm; {section!r} has "
                              + (", ".join(n for n in names if n.endswith("_mm")) or "no such section"))
        if not (math.isfinite(sd) and sd > 0):
            raise DesignError(field, f"its standard uncertainty must be a number > 0 mm, got {sd!r}")
        try:
            validate(moved_design(design, field, sd))
        except DesignError as err:
            raise DesignError(field, f"moved up by its uncertainty ({sd:g} mm) the design is refused: "
                              f"{err}") from err
        out[field] = float(sd)
    return out


def uncertainty_keys(uncertain: Mapping[str, float]) -> list[str]:
    """``design:<field>=<standard uncertainty>`` of every dimension a diagnosis states as uncertain."""
    return [f"{UNCERTAIN_PREFIX}{field}={sd:g}" for field, sd in sorted(uncertain.items())]


def moved_design(design: Design, field: str, delta_mm: float) -> Design:
    """The design with one dimension (``section.name_mm``) moved by ``delta_mm``."""
    section, _, name = field.partition(".")
    return design.replace(section, **{name: getattr(getattr(design, section), name) + delta_mm})


@dataclass(frozen=True)
class _Curve:
    """A free run up to its pressure maximum (pressure increasing), with its free length."""

    p: np.ndarray
    columns: dict[str, np.ndarray]
    free_length_mm: float

    @classmethod
    def of(cls, doc: Mapping, free_length_mm: float) -> _Curve | None:
        p = np.asarray(doc["pressure_kpa"], float)
        if p.size < 3:
            return None
        k = int(np.argmax(p)) + 1
        keep = np.concatenate([[0], 1 + np.flatnonzero(np.diff(p[:k]) > 0)])
        return cls(p[keep], {c: np.asarray(doc[c], float)[keep] for c in
                             ("bend_angle_deg", "tip_x_mm", "tip_z_mm", "cavity_volume_ml")}, free_length_mm)

    def read(self, rec: Recording, observable: str, q: np.ndarray) -> np.ndarray:
        """What ``rec`` reads of this run at the FE's pressures ``q`` (within its range)."""
        m = rec.measurement
        at = {c: np.interp(q, self.p, v) for c, v in self.columns.items()}
        if observable == "bend_angle_deg":
            return read_bend(at["bend_angle_deg"], m, self.free_length_mm)
        if observable == "volume_ml":
            rest = float(self.columns["cavity_volume_ml"][0])
            return read_volume(at["cavity_volume_ml"] - rest, rest, q, m)
        # a camera's registration is calibrated: a dimension's change is read in pnmold's frame
        rest = (float(self.columns["tip_x_mm"][0]), float(self.columns["tip_z_mm"][0]))
        x, z = read_tip(at["tip_x_mm"], at["tip_z_mm"], rest, dataclasses.replace(m, tip_origin=(
            "rest" if m.tip_origin == "rest" else "clamp")), {})
        return x if observable == "tip_x_mm" else z


@dataclass(frozen=True)
class DesignFloor:
    """The change each uncertain dimension makes to what a recording reads (see the module)."""

    nominal: _Curve | None  # None: the free run gave too few steps to read (no floor)
    moved: dict[str, _Curve]  # field -> its run at + its standard uncertainty
    uncertain: dict[str, float]
    short: tuple[str, ...] = ()  # fields whose run gave too few steps to read
    blocked: dict[str, float] = dataclasses.field(default_factory=dict)  # field -> share it changes the blocked tip

    @classmethod
    def of(cls, design: Design, c: Characterisation, uncertain: Mapping[str, float]) -> DesignFloor:
        """From the characterisation with its uncertainty runs (:func:`uncertainty_runs`)."""
        nominal = _Curve.of({k: getattr(c, k) for k in ("pressure_kpa", "bend_angle_deg", "tip_x_mm", "tip_z_mm",
                                                        "cavity_volume_ml")}, design.free_length_mm)
        moved, short = {}, []
        for field, key in zip(sorted(uncertain), uncertainty_keys(uncertain), strict=True):
            doc = c.variants.get(key)
            curve = None if doc is None else _Curve.of(doc, float(doc.get("free_length_mm", design.free_length_mm)))
            if curve is None:
                short.append(field)
            else:
                moved[field] = curve
        force = (c.blocked or {}).get("force_n")
        blocked = {field: c.variants[key]["blocked_force_n"] / force - 1.0
                   for field, key in zip(sorted(uncertain), uncertainty_keys(uncertain), strict=True)
                   if force and "blocked_force_n" in c.variants.get(key, {})}
        return cls(nominal, moved, dict(uncertain), tuple(short), blocked)

    def rows(self, rec: Recording, observable: str, scale: float) -> np.ndarray:
        """Per row of ``rec``, the standard deviation of ``observable`` the dimensions' uncertainty gives,
        the recording's pressures read at the modulus ``scale`` (the FE's at p / scale); a blocked force's,
        the shares the dimensions change the FE's blocked tip (in quadrature) times the row's force. Zero
        for what neither gives (step recordings; a force without the moved designs' blocked tips)."""
        if observable == "force_n" and rec.kind == "force":
            share = float(np.sqrt(sum(v ** 2 for v in self.blocked.values())))
            return share * np.abs(np.asarray(rec.columns[observable], float))
        p = rec.columns.get("pressure_kpa")
        if self.nominal is None or rec.kind == "step" or p is None or observable not in READ:
            return np.zeros(len(rec))
        q = np.asarray(p, float) / scale
        total = np.zeros(q.size)
        for curve in self.moved.values():
            total += self._change(rec, observable, q, curve) ** 2
        return np.sqrt(total)

    def _change(self, rec: Recording, observable: str, q: np.ndarray, curve: _Curve) -> np.ndarray:
        """The moved run less the nominal at the rows, aligned over :data:`ALIGN_RATIOS` (the moved rubber
        taken r times stiffer, least squares over the rows both reach); rows past either run's end hold
        the change at the last row both reach."""
        best, change = np.inf, np.zeros(q.size)
        for r in ALIGN_RATIOS:
            on = (q <= self.nominal.p[-1]) & (q <= curve.p[-1] * r)
            if on.sum() < 2:
                continue
            d = curve.read(rec, observable, q[on] / r) - self.nominal.read(rec, observable, q[on])
            score = float(np.mean(d ** 2))
            if score < best:
                best, change = score, np.interp(q, q[on][np.argsort(q[on])], d[np.argsort(q[on])])
        return change

    def per_recording(self, recordings: Sequence[Recording], observables, scale: float) -> list[dict[str, np.ndarray]]:
        """:meth:`rows` for every observable (``observables(rec)``) of every recording."""
        return [{name: self.rows(rec, name, scale) for name in observables(rec)} for rec in recordings]
