"""What :func:`pnmold.diagnose.diagnose` is given besides the recordings: the design it names
(:class:`DesignRef`), how far the design's FE characterisation went (:class:`Reach`) and the model
the recordings are judged against, with the settings of the judging (:class:`DiagnosisModel`).

See ``docs/diagnosis.md`` for the method and ``docs/json-schemas.md`` for the document's ``design``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .data import MODEL_FORM_SHARE, PRESSURE_FORM_SHARE
from .fitting import Forward

if TYPE_CHECKING:
    from pnmold.design import Design

#: ``design_floor(modulus_scale)``: per recording, observable -> per row, a standard deviation
DesignFloorFn = Callable[[float], list[dict[str, np.ndarray]]]


@dataclass(frozen=True)
class DesignRef:
    """The design a diagnosis is of, as its document names it (``design``).

    Parameters
    ----------
    name : str
        The design's name (a template's, or the TOML file's ``name``).
    digest : str
        The design's digest (:func:`pnmold.design.digest`): which exact design the recordings were
        judged against.
    material : str or None
        The design's rubber by name; None: not stated (the material check then says "rubber").
    kind : str or None
        The design's kind (``fpn``, ``spn``, ...); None: not stated.
    """

    name: str
    digest: str
    material: str | None = None
    kind: str | None = None

    @classmethod
    def of(cls, design: Design) -> DesignRef:
        """The reference to ``design``: its build report's ``design`` entry
        (:func:`pnmold.report.build_report.design_entry`)."""
        from pnmold.report.build_report import design_entry

        return cls(**design_entry(design))

    def as_json(self) -> dict[str, str]:
        """The document's ``design``: name, kind, digest, material in that order, those not stated left out."""
        fields = {"name": self.name, "kind": self.kind, "digest": self.digest, "material": self.material}
        return {k: v for k, v in fields.items() if v is not None}


@dataclass(frozen=True)
class Reach:
    """How far the design's FE characterisation went, to say where an answer rests on extrapolation
    (and refuse it when most of it does).

    Parameters
    ----------
    max_pressure_kpa : float
        The highest pressure the FE solved, kPa, with the design's rubber.
    full_bend_pressure_kpa : float or None
        The pressure of full bend, kPa; None: the FE stopped short of it.
    reason : str or None
        Why the FE stopped (e.g. a pressure maximum); None: not said.
    stop : str or None
        How the FE's curve ended (:attr:`pnmold.physics.characterisation.Characterisation.how_ended`);
        None: read from ``reason`` (a pressure maximum when it says so).
    """

    max_pressure_kpa: float
    full_bend_pressure_kpa: float | None = None
    reason: str | None = None
    stop: str | None = None

    @property
    def at_maximum(self) -> bool:
        """The FE's curve ended at a pressure maximum (no equilibrium past it under pressure control)."""
        return self.stop == "pressure_maximum" if self.stop else (self.reason or "").startswith("pressure maximum")


@dataclass(frozen=True, eq=False)
class DiagnosisModel:
    """The model recordings are judged against, and how.

    Parameters
    ----------
    forward : Forward
        ``forward(effects, calibration)``: per recording, observable -> per row, the model's
        prediction (:data:`pnmold.diagnose.fitting.Forward`).
    effects : sequence of catalogue entries
        The effects to consider (``pnmold effects``); those whose kinds include no recorded kind
        are left out.
    reach : Reach or None
        How far the model's FE characterisation went; None: not known (nothing said of it).
    stiffening_top_mpa : float
        > 0: the forward's model has a stiffening ladder up to this Yeoh C30, MPa
        (:func:`pnmold.diagnose.model.stiffening_top`), and ``strain_stiffening`` is fitted by its
        C30 on it; 0: no ladder.
    design_floor : callable or None
        ``design_floor(modulus_scale)``: per recording, observable -> per row, the standard deviation
        the design's stated dimensional uncertainty gives (:class:`pnmold.physics.uncertainty.DesignFloor`),
        read at that modulus: a floor under the noise, read again, once, at the calibrated modulus when
        that is over :data:`pnmold.diagnose.core.FLOOR_RESCALE` away. None: no floor.
    bootstrap_seed : int
        The seed of the bootstrap resampling.
    model_form_share : float
        The model's own form error as a share of each observable's range, the noise floor of a
        recording without repeated cycles (:data:`pnmold.diagnose.data.MODEL_FORM_SHARE`).
    pressure_form_share : float
        The model's form error in pressure as a share of the pressure, carried through the model's
        slope on quasi-static recordings (:data:`pnmold.diagnose.data.PRESSURE_FORM_SHARE`).
    """

    forward: Forward
    effects: Sequence[Any]
    reach: Reach | None = None
    stiffening_top_mpa: float = 0.0
    design_floor: DesignFloorFn | None = None
    bootstrap_seed: int = 0
    model_form_share: float = MODEL_FORM_SHARE
    pressure_form_share: float = PRESSURE_FORM_SHARE

    def __post_init__(self) -> None:
        object.__setattr__(self, "effects", tuple(self.effects))
