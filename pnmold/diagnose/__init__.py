"""Missing-physics diagnosis: recordings against the reduced model (DIAGNOSE.md).

recordings -> calibrate the nominal model -> locate the mismatch -> rank, fit and accept
catalogued effects on held-out blocks -> explain -> ``pnmold.diagnosis/1`` JSON and a report.
"""

from .core import SCHEMA, Diagnosis, diagnose
from .fitting import Forward

__all__ = ["SCHEMA", "Diagnosis", "Forward", "diagnose"]
