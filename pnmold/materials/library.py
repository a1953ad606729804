"""Elastomers for casting PneuNets, with the source of every value.

Each :class:`Material` carries ``sources``: field name -> citation (datasheet, paper, or a
pnmold fit of published data), or a text containing "assumed". Yeoh constants are for
incompressible Yeoh, ``W = C10 (I1-3) + C20 (I1-3)^2 + C30 (I1-3)^3``, valid over
``fit_strain_range`` (engineering strain).
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from pnmold.errors import UsageError

#: the keys of the design's ``[material]`` section that a library material fills in
DESIGN_KEYS = ("name", "c10_mpa", "c20_mpa", "c30_mpa", "density_g_per_ml", "mix_ratio_a_to_b")

SI = "Mosadegh et al., Adv. Funct. Mater. 2014, Supporting Information"
WACKER = "Wacker ELASTOSIL M 4601 A/B technical data sheet (as recalled from; edition not checked)"
ECOFLEX = "Smooth-On Ecoflex Series technical bulletin, Ecoflex 00-30"
DRAGON = "Smooth-On Dragon Skin Series technical bulletin, Dragon Skin 30"
MARECHAL = ("Marechal et al., 'Toward a Common Framework and Database of Materials for Soft Robotics', "
            "Soft Robotics 8(3), 2021; data: github.com/LucMarechal/Soft-Robotics-Materials-Database (ODbL 1.0)")
#: the pnmold fit rule that decides a fit's valid strain range (see pnmold.materials.fit)
_RANGE_RULE = "range where that fit holds (pnmold rule: R^2 >= 0.99, local error <= 10 %)"


@dataclass(frozen=True)
class Cure:
    """One cure schedule: time at temperature."""

    hours: float
    temperature_c: float


@dataclass(frozen=True)
class Material:
    """A two-part casting elastomer: hyperelastic constants, handling and strength."""

    name: str
    c10_mpa: float
    c20_mpa: float
    c30_mpa: float
    density_g_per_ml: float
    mix_ratio_a_to_b: float
    mix_by: str
    pot_life_min: float
    cure: tuple[Cure, ...]
    elongation_at_break: float
    tensile_strength_mpa: float
    shore_hardness: str
    fit_strain_range: tuple[float, float]
    sources: Mapping[str, str] = field(compare=False, repr=False)
    aliases: tuple[str, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "sources", MappingProxyType(dict(self.sources)))

    @property
    def initial_shear_modulus_mpa(self) -> float:
        """Small-strain shear modulus ``2 C10`` (MPa)."""
        return 2.0 * self.c10_mpa

    def source(self, field_name: str) -> str:
        """The citation of one field's value, or "assumed"."""
        return self.sources.get(field_name, "assumed")


ELASTOSIL = Material(
    name="Elastosil M4601",
    c10_mpa=0.11, c20_mpa=0.02, c30_mpa=0.0,
    density_g_per_ml=1.13, mix_ratio_a_to_b=9.0, mix_by="weight",
    pot_life_min=90.0, cure=(Cure(12.0, 23.0),),
    elongation_at_break=7.0, tensile_strength_mpa=6.5, shore_hardness="Shore A 28",
    fit_strain_range=(0.0, 1.0),
    aliases=("M4601", "Elastosil M 4601"),
    sources={
        "name": f"{SI}: Elastosil M4601 (Wacker Chemical Corp.)",
        "c10_mpa": f"{SI}, FE model: C10 = 0.11 MPa (Yeoh, N = 3)",
        "c20_mpa": f"{SI}, FE model: C20 = 0.02 MPa",
        "c30_mpa": f"{SI}, FE model: C30 = 0",
        "density_g_per_ml": f"{WACKER}: density 1.13 g/cm3",
        "mix_ratio_a_to_b": f"{WACKER}: A:B = 9:1 by weight",
        "mix_by": f"{WACKER}: by weight",
        "pot_life_min": f"{WACKER}: pot life about 90 min at 23 C",
        "cure": f"{WACKER}: cured after about 12 h at 23 C",
        "elongation_at_break": f"{WACKER}: elongation at break about 700 %",
        "tensile_strength_mpa": f"{WACKER}: tensile strength about 6.5 N/mm2",
        "shore_hardness": f"{WACKER}: Shore A 28 (the supplement's Fabrication paragraph says 'shore A30')",
        "fit_strain_range": "assumed: the supplement fits compression and tension tests (Fig. S4) "
                            "but its text gives no strain range; 0 to 1 is what the actuator walls see",
    },
)

_ECOFLEX = Material(
    name="Ecoflex 00-30",
    c10_mpa=0.008167, c20_mpa=7.371e-05, c30_mpa=0.0,
    density_g_per_ml=1.07, mix_ratio_a_to_b=1.0, mix_by="weight",
    pot_life_min=45.0, cure=(Cure(4.0, 23.0),),
    elongation_at_break=9.0, tensile_strength_mpa=1.38, shore_hardness="Shore 00-30",
    fit_strain_range=(0.341, 5.909),
    aliases=("Ecoflex 30", "Ecoflex0030"),
    sources={
        "name": f"{ECOFLEX} (Smooth-On Inc.); the supplement's 'Ecoflex 30'",
        "c10_mpa": (f"pnmold Yeoh fit (fit_hyperelastic, C20, C30 >= 0, eng. strain <= 6, R^2 = 0.99977) of the "
                    f"Ecoflex 00-30 pull-to-failure test of {MARECHAL}, tests/data/ecoflex0030_uniaxial_tension.csv"),
        "c20_mpa": "same pnmold Yeoh fit as c10_mpa",
        "c30_mpa": "same pnmold Yeoh fit as c10_mpa (bound at 0: the design requires C30 >= 0)",
        "density_g_per_ml": f"{ECOFLEX}: specific gravity 1.07 g/cc",
        "mix_ratio_a_to_b": f"{ECOFLEX}: 1A:1B by volume or weight",
        "mix_by": f"{ECOFLEX}: by volume or weight (same ratio, near-equal densities); pnmold weighs",
        "pot_life_min": f"{ECOFLEX}: pot life 45 min",
        "cure": f"{ECOFLEX}: cure time 4 h at room temperature (23 C)",
        "elongation_at_break": f"{ECOFLEX}: elongation at break 900 %",
        "tensile_strength_mpa": f"{ECOFLEX}: tensile strength 200 psi (1.38 MPa)",
        "shore_hardness": f"{ECOFLEX}: Shore 00-30",
        "fit_strain_range": f"{_RANGE_RULE}; points below 0.34 (toe region) fall outside 10 %",
    },
)

_DRAGON_SKIN = Material(
    name="Dragon Skin 30",
    c10_mpa=0.09631, c20_mpa=0.00663, c30_mpa=0.0,
    density_g_per_ml=1.08, mix_ratio_a_to_b=1.0, mix_by="weight",
    pot_life_min=45.0, cure=(Cure(16.0, 23.0),),
    elongation_at_break=3.64, tensile_strength_mpa=3.45, shore_hardness="Shore 30A",
    fit_strain_range=(0.227, 1.477),
    aliases=("DragonSkin30", "DS30"),
    sources={
        "name": f"{DRAGON} (Smooth-On Inc.)",
        "c10_mpa": (f"pnmold Yeoh fit (fit_hyperelastic, C20, C30 >= 0, eng. strain <= 1.5, R^2 = 0.99896) of the "
                    f"engineering columns, read every 0.5 s, of Tensile-Tests-Data/Dragon Skin 30.csv in {MARECHAL}"),
        "c20_mpa": "same pnmold Yeoh fit as c10_mpa",
        "c30_mpa": "same pnmold Yeoh fit as c10_mpa (bound at 0: the design requires C30 >= 0)",
        "density_g_per_ml": f"{DRAGON}: specific gravity 1.08 g/cc",
        "mix_ratio_a_to_b": f"{DRAGON}: 1A:1B by volume or weight",
        "mix_by": f"{DRAGON}: by volume or weight (same ratio, near-equal densities); pnmold weighs",
        "pot_life_min": f"{DRAGON}: pot life 45 min",
        "cure": f"{DRAGON}: cure time 16 h at room temperature (23 C)",
        "elongation_at_break": f"{DRAGON}: elongation at break 364 %",
        "tensile_strength_mpa": f"{DRAGON}: tensile strength 500 psi (3.45 MPa)",
        "shore_hardness": f"{DRAGON}: Shore 30A",
        "fit_strain_range": (f"{_RANGE_RULE}; this nearly linear rubber needs C20 < 0 beyond strain 1.5, "
                             "which the design refuses"),
    },
)

#: the default elastomer of a design and of the FE (the supplement's)
_MATERIALS = (ELASTOSIL, _ECOFLEX, _DRAGON_SKIN)


def _key(name: str) -> str:
    return re.sub(r"[^a-z0-9]", "", name.lower())


_BY_KEY = {_key(n): m for m in _MATERIALS for n in (m.name, *m.aliases)}


def list_materials() -> list[Material]:
    """Every material in the library, in a fixed order."""
    return list(_MATERIALS)


def find_material(name: str) -> Material | None:
    """A material by name (as :func:`get_material`), or None when the library has none of that name."""
    return _BY_KEY.get(_key(name))


def get_material(name: str) -> Material:
    """A material by name, ignoring case, spaces and dashes ("ecoflex-00-30" works)."""
    try:
        return _BY_KEY[_key(name)]
    except KeyError:
        known = ", ".join(m.name for m in _MATERIALS)
        raise UsageError(f"unknown material {name!r}; known materials: {known}") from None


def as_design_overrides(material: Material) -> list[str]:
    """``section.key=value`` strings that put ``material`` in a design's ``[material]`` section.

    Pass them to ``load_design(ref, overrides)`` or as ``--set`` options; values are TOML.
    """
    out = []
    for key in DESIGN_KEYS:
        value = getattr(material, key)
        text = json.dumps(value) if isinstance(value, str) else repr(float(value))
        out.append(f"material.{key}={text}")
    return out
