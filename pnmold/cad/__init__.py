"""CadQuery models of the cast parts and molds. The only package that imports CadQuery."""

from pnmold.cad.build import export_actuator_step, export_parts, make_parts

__all__ = ["export_actuator_step", "export_parts", "make_parts"]
