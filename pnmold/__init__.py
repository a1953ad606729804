"""pnmold: PneuNet bending actuators from one design file to molds, checks, FE and diagnosis.

The public API::

    from pnmold import load_design, build
    design = load_design("fpn", ["chambers.count=9"])       # template + overrides
    taller = design.replace("chambers", height_mm=12.0)      # a new value, no mutation
    result = build(taller, "out/fpn-tall")                   # STEP, STL, report.json
"""

from pnmold.version import __version__

__all__ = ["build", "load_design", "__version__"]


def __getattr__(name: str):
    # lazy, so `import pnmold` stays light (CadQuery loads only when building)
    if name == "load_design":
        from pnmold.design import load_design

        return load_design
    if name == "build":
        from pnmold.pipeline import build

        return build
    raise AttributeError(name)
