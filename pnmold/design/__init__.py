"""Designs: frozen dataclasses from TOML templates, with rules checked before any CAD."""

from pnmold.design.load import (
    as_dict,
    coerce_value,
    digest,
    field_type,
    list_templates,
    load_design,
    templates_dir,
    to_toml,
)
from pnmold.design.model import SECTIONS, Design
from pnmold.design.rules import validate

__all__ = ["Design", "SECTIONS", "as_dict", "coerce_value", "digest", "field_type", "list_templates",
           "load_design", "templates_dir", "to_toml", "validate"]
