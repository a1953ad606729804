"""The nominal parameters recalibrated before any physics is blamed (docs/diagnosis.md: calibrate first).

- **The rubber's modulus.** A plain stiffness error (another batch of rubber, a thinner wall)
  scales the modulus within +-40 % (``WINDOW``, assumed: batch-to-batch and cure variation of
  platinum silicones). A *wrong material* does not: a segment cast in a harder silicone than
  the design names needs ten times the modulus. So the modulus is first found over a wide
  range (``WIDE``, on a log grid, then refined); when it falls outside the window, the
  diagnosis says so in plain words (the material is the first thing to check, not physics)
  and judges the effects around the modulus found, with the usual window about it.
- **The rubber's density.** A batch weighs a little more or less than the datasheet's (trapped air,
  pigment, filler): where a recording's gravity acts in the bending plane the weight is calibrated
  within +-10 % (``DENSITY_WINDOW``, assumed) with the modulus. A weight further off is not a batch:
  it is named ``gravity`` (the data show another gravity than the declared one), and the gravity
  hypothesis carries the density with it.
- **The camera frame.** A recording whose tip is measured in a frame of its own (metadata
  ``tip_origin: camera``) calibrates the frame's offset and rotation with the modulus
  (:data:`pnmold.physics.reading.FRAME`): registration, never an effect. Its turn is held within
  +-10 degrees (``ROTATION_WINDOW``, assumed: a camera set level by eye); a turn or an offset pinned at
  its bound is said, with what to check.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pnmold.physics.reading import FRAME
from pnmold.physics.rom import CALIBRATION

from .fitting import Fitter, Hypothesis, Parameter

#: the modulus window about the nominal: a stiffness error, not a different material (assumed)
WINDOW = (0.6, 1.6)
#: where a wrong material is looked for: the reduced model's own bounds (assumed there: Ecoflex
#: 00-10 to a Shore A 40 rubber is ~50x)
WIDE = CALIBRATION["modulus_scale"][1]
WIDE_POINTS = 43  # log grid: about 10 % apart
#: a final modulus further than this share from the material check's is said too
SETTLED_SHARE = 0.02
#: the batch's density about the design's rubber's (assumed: air or filler in a cast silicone)
DENSITY_WINDOW = (0.9, 1.1)
#: a camera frame's turn (degrees) a registration may take (assumed: a camera set level by eye); its
#: offsets keep the reduced model's bounds (the camera's origin is the lab's choice)
ROTATION_WINDOW = (-10.0, 10.0)


@dataclass(frozen=True)
class MaterialCheck:
    """The modulus the recordings need (``scale``, a multiple of the design's) and what it means."""

    scale: float
    in_window: bool
    message: str | None
    chi2: float = float("nan")  # the modulus-only fit's misfit at ``scale`` (every row)

    def as_json(self) -> dict:
        return {"modulus_scale": round(self.scale, 6), "window": list(WINDOW), "in_window": self.in_window,
                "message": self.message}


def frame_parameters() -> tuple[Parameter, ...]:
    windows = {"frame_rotation_deg": ROTATION_WINDOW}
    return tuple(Parameter(k, nominal, *windows.get(k, bounds), calibration=True)
                 for k, (nominal, bounds) in FRAME.items())


def calibration_parameters(nominal_scale: float = 1.0, frame: bool = False, density: bool = False
                           ) -> tuple[Parameter, ...]:
    """The modulus (the window about ``nominal_scale``), with ``density`` the batch's density (the weight
    acts in the bending plane) and, for a camera frame, its registration."""
    lo, hi = max(WINDOW[0] * nominal_scale, WIDE[0]), min(WINDOW[1] * nominal_scale, WIDE[1])
    modulus = Parameter("modulus_scale", min(max(nominal_scale, lo), hi), lo, hi, calibration=True)
    weight = (Parameter("density_scale", 1.0, *DENSITY_WINDOW, calibration=True),) if density else ()
    return (modulus, *weight, *(frame_parameters() if frame else ()))


def weighs_in_plane(recordings) -> bool:
    """A quasi-static recording whose declared orientation puts the actuator's weight in its bending
    plane (chambers up or down, submerged): its density is then a nuisance to calibrate."""
    return any(r.kind != "step" and r.orientation in ("chambers_up", "chambers_down", "submerged")
               for r in recordings)


def reach_scale(predictions: list[dict[str, np.ndarray]]) -> float:
    """The least modulus scale at which the model (predicted at scale 1, the effects off) reaches every
    row: a row past its pressure maximum by the share e needs the rubber 1/(1 - e) times stiffer (the
    pressures of the free law scale with the modulus). 0 when every row is reached."""
    excess = [np.asarray(pred["pressure_excess"], float) for pred in predictions if "pressure_excess" in pred]
    top = max((float(np.max(e, initial=0.0)) for e in excess), default=0.0)
    return 1.0 / (1.0 - top) * (1.0 + 1e-3) if top > 0 else 0.0


def check_material(fitter: Fitter, frame: bool, material: str, reach: float = 0.0, density: bool = False
                   ) -> MaterialCheck:
    """The best modulus over :data:`WIDE` (the effects off), refined; a message when it is outside the
    window: which way the model is off, by how much, and what to check. ``reach``: the least modulus
    at which the model reaches every row (:func:`reach_scale`): the search starts there (a softer
    rubber than the recordings' highest pressure allows is not a candidate, whatever the effects)."""
    h = Hypothesis((), calibration_parameters(1.0, frame, density))
    rest = np.array([p.start for p in h.parameters[1:]])
    floor = min(max(WIDE[0], reach), WIDE[1])
    grid = np.geomspace(floor, WIDE[1], WIDE_POINTS)
    chi2 = [float(np.sum(fitter.z(h, np.concatenate([[s], rest])) ** 2)) for s in grid]
    best = float(grid[int(np.argmin(chi2))])
    near = Hypothesis((), calibration_parameters(best, frame, density))
    modulus, *rest_params = near.parameters  # the wide search widens the modulus alone
    wide = Hypothesis((), (Parameter(modulus.key, modulus.start, max(modulus.low, floor), min(modulus.high, WIDE[1]),
                                     True), *rest_params))
    fit = fitter.fit(wide, starts=[np.array([p.start for p in wide.parameters])])
    scale = min(max(float(fit.x[0]), floor), WIDE[1])  # the fit may step a rounding past its bound
    if WINDOW[0] <= scale <= WINDOW[1]:
        return MaterialCheck(scale, True, None, fit.chi2)
    way = "stiffer" if scale > 1 else "softer"
    factor = scale if scale > 1 else 1 / scale
    held = (f" (the recordings hold pressures past the model's pressure maximum with the design's rubber: "
            f"it must be at least {reach:.3g} times stiffer)" if reach > WINDOW[1] else "")
    return MaterialCheck(scale, False, (
        f"The recordings need a rubber {factor:.3g} times {way} than the design's {material} (modulus scale "
        f"{scale:.3g}, outside the {WINDOW[0]:g}-{WINDOW[1]:g} a batch or cure varies by){held}: check the "
        f"material first (its name, Shore hardness, mix ratio, cure), then the wall thicknesses. The effects "
        f"below are judged about this modulus."), fit.chi2)


def _pinned(value: float, p: Parameter) -> str | None:
    span = p.high - p.low
    return "lower" if value <= p.low + 0.01 * span else "upper" if value >= p.high - 0.01 * span else None


def modulus_pinned(decision, calibration: tuple[Parameter, ...]) -> bool:
    """The modulus sits at a bound of its window in the final model and in the best candidate's fit
    too: more than a batch of rubber varies, and no catalogued effect frees it (an effect that does,
    even one not accepted, is the likelier story than another rubber: the trap docs/diagnosis.md warns of)."""
    fits = [decision.final, *decision.ranked[:1]]
    return all(_pinned(c.fit.values["modulus_scale"], calibration[0]) is not None for c in fits)


def baseline_pinned(decision, calibration: tuple[Parameter, ...]) -> bool:
    """The recalibrated nominal model alone has its modulus at a bound of the window."""
    return _pinned(decision.baseline.fit.values["modulus_scale"], calibration[0]) is not None


def other_rubber_fits(check: MaterialCheck, decision, margin: float) -> bool:
    """Another rubber (the material check's modulus, no effect) fits the data within ``margin``
    (chi-square) of the best candidate that freed the window's modulus: that effect only stood in
    for a modulus the window did not allow (on one first loading a Mullins factor is a modulus
    scale), so it is not evidence against another rubber (docs/diagnosis.md: judge a term only by what
    recalibration could not absorb)."""
    best = min((c.fit.chi2 for c in decision.ranked[:1]), default=float("inf"))
    return check.chi2 <= best + margin


def calibration_notes(final, calibration: tuple[Parameter, ...], check: MaterialCheck | None) -> list[str]:
    """Plain words on the calibration: a wrong material, and a value pinned at its bound (which way
    and by how much the model is off, and what to check) instead of physics."""
    notes = [check.message] if check is not None and check.message else []
    settled = final.fit.values["modulus_scale"]
    if notes and abs(settled / check.scale - 1.0) > SETTLED_SHARE:
        notes.append(f"With the effects fitted, the modulus settled at {settled:.3g} x the design's.")
    for p in calibration:
        if p.key not in final.fit.values:  # the density, carried by a named gravity
            continue
        v = final.fit.values[p.key]
        side = _pinned(v, p)
        if side is not None:
            if p.key == "modulus_scale":
                notes.append(f"The modulus calibration is pinned at its {side} bound ({v:.3g} x the design's): the "
                             f"recordings want a {'softer' if side == 'lower' else 'stiffer'} actuator than a batch "
                             f"of rubber varies by; check the material and the wall thicknesses before any physics.")
            elif p.key == "density_scale":
                notes.append(f"The rubber's density calibration is pinned at its {side} bound ({v:.3g} x the "
                             f"design's): the actuator sags {'less' if side == 'lower' else 'more'} than a batch's "
                             f"weight explains; check the orientation and whether anything holds or loads the tip.")
            elif p.key == "frame_rotation_deg":
                notes.append(f"The camera frame's turn is pinned at its {side} bound ({v:.3g} deg, more than a "
                             f"camera set level by eye): the turn stands in for a misfit of the model; check the "
                             f"recording's axes (x along the actuator, z up from its bottom face).")
            else:
                notes.append(f"The camera frame's {p.key} is pinned at its {side} bound ({v:.3g}): check the "
                             f"recording's axes (x along the actuator, z up from its bottom face) and units.")
    return notes
