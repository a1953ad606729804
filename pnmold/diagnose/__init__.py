"""Missing-physics diagnosis: recordings against the reduced model (``docs/diagnosis.md``).

recordings -> calibrate the nominal model -> locate the mismatch -> rank, fit and accept
catalogued effects on held-out blocks -> explain -> ``pnmold.diagnosis/1`` JSON and a report.
"""

from .core import SCHEMA, Diagnosis, diagnose
from .fitting import Forward
from .inputs import DesignRef, DiagnosisModel, Reach

__all__ = ["SCHEMA", "DesignRef", "Diagnosis", "DiagnosisModel", "Forward", "Reach", "diagnose"]
