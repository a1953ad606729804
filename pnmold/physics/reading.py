"""What a recording reads of the model's state, given how it was measured (:mod:`pnmold.recording.measurement`).

- **Bend angle over another length.** A lab that computes the angle as curvature x its own
  bending length L_b reads, on a constant-curvature bend, the model's angle x L_b / L_free
  (L_free: the actuator's free length, from the clamp to the tip).
- **Tip frame.** ``clamp``: pnmold's frame, as is. ``rest``: the tip less its rest position
  (0 kPa, gravity included). ``camera``: rotated by ``frame_rotation_deg`` about the frame's
  origin and offset by (``frame_dx_mm``, ``frame_dz_mm``): nuisance values the diagnosis
  calibrates with the modulus.
- **P-V rig.** Isothermal gas (the walls hold the temperature). With water (the supplement's
  syringe pump), the injected water is the cavity's volume change plus the compression of any
  trapped air V_a: ``dV + V_a p / (p_atm + p)``. With air driven by a piston, the piston also
  compresses the cavity's own air V_c0, the rig's air column and any dead volume:
  ``dV + (V_c0 + V_a) p / (p_atm + p)``. With air metered in by a regulator (standard mL at 0 degC,
  101.325 kPa): ``((p_atm + p)(V_c0 + V_a + dV) - p_atm (V_c0 + V_a)) / p_std x T_std / T``.
  V_a = the recording's ``air_column_ml`` + the ``dead_volume`` effect.
- **Read by volume.** A rig that sets the volume over one loading ramp is asked for the pressure at
  each recorded volume (:func:`at_volumes`): the model's curve along rising pressure, its volume
  read as above, inverted. A volume past the model's reach (its pressure maximum: the FE's curve
  ends there) gets the state at the maximum and the share of its volume the model cannot take
  (``volume_excess``; a stiffer rubber does not help there: its volumes at the maximum are the same).

Pure functions on arrays: no FE, no files.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from pnmold.recording.measurement import Measurement

#: standard atmosphere (ISO 2533) and the reference conditions of standard mL (0 degC, 101.325 kPa)
P_ATM_KPA = 101.325
T_STD_K = 273.15
#: the lab's gas temperature (assumed: room temperature, 20 degC)
T_LAB_K = 293.15
#: calibration keys of a camera frame: nominal value and bounds (assumed: a camera placed within
#: 200 mm and 45 degrees of pnmold's frame; beyond that the recording's axes are not x and z)
FRAME = {"frame_dx_mm": (0.0, (-200.0, 200.0)), "frame_dz_mm": (0.0, (-200.0, 200.0)),
         "frame_rotation_deg": (0.0, (-45.0, 45.0))}


def read_bend(bend_deg: np.ndarray, m: Measurement, free_length_mm: float) -> np.ndarray:
    """The bend angle as the recording computes it."""
    return bend_deg if m.bending_length_mm is None else bend_deg * (m.bending_length_mm / free_length_mm)


def read_tip(tip_x_mm: np.ndarray, tip_z_mm: np.ndarray, rest_xz_mm: tuple[float, float], m: Measurement,
             frame: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The tip in the recording's frame (``frame``: the camera's calibrated offset and rotation)."""
    if m.tip_origin == "rest":
        return tip_x_mm - rest_xz_mm[0], tip_z_mm - rest_xz_mm[1]
    if m.tip_origin == "camera":
        a = math.radians(frame.get("frame_rotation_deg", 0.0))
        x = math.cos(a) * tip_x_mm - math.sin(a) * tip_z_mm + frame.get("frame_dx_mm", 0.0)
        z = math.sin(a) * tip_x_mm + math.cos(a) * tip_z_mm + frame.get("frame_dz_mm", 0.0)
        return x, z
    return tip_x_mm, tip_z_mm


def read_volume(volume_change_ml: np.ndarray, cavity_rest_ml: float, pressure_kpa: np.ndarray, m: Measurement,
                dead_volume_ml: float = 0.0) -> np.ndarray:
    """The volume a P-V test records: see the module docstring (gauge kPa, mL)."""
    p = np.asarray(pressure_kpa, float)
    trapped = m.air_column_ml + dead_volume_ml
    if m.medium == "water":
        return volume_change_ml + trapped * p / (P_ATM_KPA + p)
    gas = cavity_rest_ml + trapped
    if m.rig == "volume":
        return volume_change_ml + gas * p / (P_ATM_KPA + p)
    return ((P_ATM_KPA + p) * (gas + volume_change_ml) - P_ATM_KPA * gas) / P_ATM_KPA * T_STD_K / T_LAB_K


def at_volumes(curve: Mapping[str, np.ndarray], volume_ml: np.ndarray) -> dict[str, np.ndarray]:
    """The model's ``curve`` (columns along rising pressure: ``pressure_kpa``, ``volume_ml`` as the rig reads
    it, ``pressure_excess`` > 0 where the model has no equilibrium) read at the recorded ``volume_ml``.

    Every column is interpolated along the volume over the curve's reachable part (up to its first row
    without an equilibrium, the volume kept rising). Past its last volume: where the curve ends at the
    model's pressure maximum, the state there, with ``volume_excess`` the share of the row's volume the
    model cannot take (1 - V_top / V; ``pressure_excess`` is 0: every row is read at a pressure the model
    holds); where it ends only because the pressures asked stop, extrapolated
    along its last slope. ``volume_ml`` is the recorded one."""
    v_rec = np.asarray(volume_ml, float)
    vol = np.asarray(curve["volume_ml"], float)
    ok = np.isfinite(vol) & (np.asarray(curve["pressure_excess"], float) <= 0)
    end = int(np.argmin(ok)) if not ok.all() else ok.size
    if end < 2:
        raise ValueError("the model's curve holds fewer than two states in reach")
    rising = np.concatenate([[True], np.diff(np.maximum.accumulate(vol[:end])) > 0])
    idx = np.flatnonzero(rising)
    v = vol[idx]
    ended = end < ok.size  # the curve stops at the model's pressure maximum
    out: dict[str, np.ndarray] = {}
    for key, column in curve.items():
        col = np.asarray(column)
        if col.ndim != 1 or col.size != vol.size or key in ("volume_ml", "pressure_excess"):
            continue
        y = col[idx].astype(float)
        got = np.interp(v_rec, v, y)
        if not ended:
            slope = (y[-1] - y[-2]) / (v[-1] - v[-2])
            got = np.where(v_rec > v[-1], y[-1] + slope * (v_rec - v[-1]), got)
        out[key] = got > 0.5 if col.dtype == bool else got
    out["volume_ml"] = v_rec.copy()
    beyond = v_rec > v[-1]
    out["volume_excess"] = np.where(beyond & ended, 1.0 - v[-1] / np.maximum(v_rec, v[-1]), 0.0)
    out["pressure_excess"] = np.zeros_like(v_rec)
    if "beyond_fe" in out:
        out["beyond_fe"] = out["beyond_fe"] | beyond
    return out
