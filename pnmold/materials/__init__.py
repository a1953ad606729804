"""Elastomers for casting PneuNets (with sources), and hyperelastic fits of tensile tests."""

from pnmold.materials.fit import MODELS, FitResult, TensileData, fit_command, fit_hyperelastic, read_tensile
from pnmold.materials.library import Cure, Material, as_design_overrides, get_material, list_materials

__all__ = ["MODELS", "Cure", "FitResult", "Material", "TensileData", "as_design_overrides", "fit_command",
           "fit_hyperelastic", "get_material", "list_materials", "read_tensile"]
