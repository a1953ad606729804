"""Units pnmold reads in lab files, converted once at reading to its own (docs/frame-and-units.md:
kPa gauge, mL): the factors, each with its definition. A leaf module."""

from __future__ import annotations

#: lbf/in^2 in kPa, exact from the definitions of the pound (0.45359237 kg), standard gravity
#: (9.80665 m/s^2) and the inch (0.0254 m); NIST SP 811 (2008) App. B.8 rounds it to 6.894 757 kPa
PSI_KPA = 0.45359237 * 9.80665 / 0.0254**2 / 1000.0
#: gauge-pressure units of a column name's ending -> kPa per unit: SI prefixes of the pascal;
#: 1 bar = 100 kPa exactly (NIST SP 811 (2008) Table 9); psi as above; "g" marks gauge (psig, barg)
PRESSURE_UNITS = {"kpa": 1.0, "pa": 1e-3, "mpa": 1e3, "bar": 100.0, "mbar": 0.1, "psi": PSI_KPA,
                  "kpag": 1.0, "barg": 100.0, "psig": PSI_KPA}
#: absolute-pressure endings, refused: pnmold's pressures are gauge (above the atmosphere)
ABSOLUTE_UNITS = ("kpaa", "bara", "psia")
#: volume units of a column name's ending -> mL per unit: 1 L = 1 dm^3 (SI Brochure, 9th ed. 2019,
#: Table 8), so 1 mL = 1 cm^3 = 1 cc (NIST SP 811 (2008) App. B.8) and 1 uL = 0.001 mL
VOLUME_UNITS = {"ml": 1.0, "ul": 1e-3, "cc": 1.0, "cm3": 1.0, "l": 1e3}
