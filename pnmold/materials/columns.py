"""The columns of a tensile-test file: what each one holds, and in which unit.

A header cell such as ``Engineering Stress (MPa)``, ``eng_stress_mpa``, ``Stress [kPa]`` or
``Load (N)`` is split into a name and a unit (in brackets, or the last ``_``/space-separated
word when it is a unit); the name, without case, spaces and punctuation, says the column's
role (:data:`ROLES`), the unit the factor to pnmold's (:data:`UNITS`). Pure functions on strings.
"""

from __future__ import annotations

import re

from pnmold.recording.units import PRESSURE_UNITS, PSI_KPA

#: role -> the names that mean it (lower case, letters and digits only)
ROLES = {
    "strain": ("engineeringstrain", "engstrain", "strain", "nominalstrain", "tensilestrain"),
    "true_strain": ("truestrain", "logarithmicstrain", "logstrain", "henckystrain"),
    "stress": ("engineeringstress", "engstress", "stress", "nominalstress", "tensilestress"),
    "true_stress": ("truestress", "cauchystress", "truetensilestress"),
    "force": ("force", "load", "tensileload", "tensileforce", "standardforce"),
    "extension": ("extension", "tensileextension", "elongation", "displacement", "crossheaddisplacement", "stroke"),
    "mode": ("mode",),
}
#: role -> the dimension of its unit
DIMENSION = {"strain": "strain", "true_strain": "strain", "stress": "stress", "true_stress": "stress",
             "force": "force", "extension": "length"}
#: dimension -> unit (lower case) -> factor to pnmold's unit (strain: ratio, stress: MPa, force: N,
#: length: mm, area: mm^2). Pressures are units.PRESSURE_UNITS / 1000 (SI prefixes, the bar
#: and psi as cited there); 1 N/mm^2 = 1 MPa (SI); 1 ksi = 1000 psi; 1 lbf = 0.45359237 kg x
#: 9.80665 m/s^2 = 4.4482216152605 N exactly (NIST SP 811 (2008) App. B.8: 4.448 222 N);
#: 1 in = 25.4 mm exactly (NIST SP 811 (2008) App. B.8); % is a hundredth.
UNITS = {
    "strain": {"": 1.0, "-": 1.0, "ratio": 1.0, "mm/mm": 1.0, "m/m": 1.0, "in/in": 1.0, "%": 0.01, "pct": 0.01,
               "percent": 0.01},
    "stress": {**{u: f / 1000.0 for u, f in PRESSURE_UNITS.items() if not u.endswith("g")},
               "gpa": 1000.0, "n/mm2": 1.0, "n/mm^2": 1.0, "n/m2": 1e-6, "n/m^2": 1e-6, "ksi": PSI_KPA},
    "force": {"n": 1.0, "kn": 1000.0, "lbf": 0.45359237 * 9.80665},
    "length": {"mm": 1.0, "m": 1000.0, "cm": 10.0, "um": 1e-3, "in": 25.4},
    "area": {"mm2": 1.0, "mm^2": 1.0, "cm2": 100.0, "cm^2": 100.0, "m2": 1e6, "m^2": 1e6, "in2": 645.16,
             "in^2": 645.16},
}
_PLAIN = str.maketrans({"\u00b5": "u", "\u03bc": "u", "\u00b2": "2", " ": ""})
_BRACKETS = re.compile(r"^(.*?)\s*[(\[]\s*([^)\]]*)\s*[)\]]\s*$")


def normal_unit(text: str) -> str:
    """A unit as the tables spell it: lower case, no spaces, micro as u, superscript 2 as 2."""
    return text.strip().lower().translate(_PLAIN)


def is_unit(text: str) -> bool:
    """Whether ``text`` is a unit of any dimension (``(mm)`` and ``[N]`` count, blank does not)."""
    m = _BRACKETS.match(text.strip())
    unit = normal_unit(m.group(2) if m and not m.group(1) else text)
    return bool(unit) and any(unit in table for table in UNITS.values())


def split_name(cell: str, *, as_written: bool = False) -> tuple[str, str | None]:
    """A header cell as (role name: lower case, letters and digits only; its unit or None). The
    unit as :func:`normal_unit` spells it, or ``as_written``."""
    text = cell.strip()
    m = _BRACKETS.match(text)
    if m:
        return _key(m.group(1)), m.group(2).strip() if as_written else normal_unit(m.group(2))
    _, sep, last = re.split(r"([_\s]+)", text)[-3:] if re.search(r"[_\s]", text) else (text, "", "")
    if sep and normal_unit(last) and any(normal_unit(last) in table for table in UNITS.values()):
        return _key(text[: len(text) - len(last)]), last if as_written else normal_unit(last)
    return _key(text), None


def _key(name: str) -> str:
    return re.sub(r"[^a-z0-9]", "", name.lower())


def role_of(name: str) -> str | None:
    """The role of a role name (:func:`split_name`), or None for a column pnmold does not read."""
    return next((role for role, names in ROLES.items() if name in names), None)


def factor(role: str, unit: str | None) -> float | None:
    """The factor from ``unit`` to pnmold's unit for ``role``; None when the unit is not one of its
    dimension (a strain without a unit is a ratio; other roles need one)."""
    table = UNITS[DIMENSION[role]]
    if unit is None:
        return 1.0 if DIMENSION[role] == "strain" else None
    return table.get(normal_unit(unit))
