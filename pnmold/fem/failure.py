"""What a failed solve reports: where in the body it went wrong and what to try.

Turns a :class:`~.path.PathFailure` into the text of a :class:`~pnmold.errors.SolveError`:
the stage, the load reached, the region (the tetrahedra that inverted at a trial state,
or else the nodes carrying most of the remaining residual: their x-range and the named
boundaries they touch) and a hint per stage.
"""

from __future__ import annotations

import numpy as np

from .model import Model

HINTS = {
    "gravity": ("the body may not carry its own weight this way at this mesh: try a finer "
                "mesh (MeshSize wall_mm/max_mm), another orientation, or no gravity to "
                "separate the two effects"),
    "pressure": ("try a finer mesh in that region (walls about one element thick invert "
                 "first), smaller bend increments (SolveOptions.max_angle_step_deg) or a "
                 "lower max_pressure_kpa"),
    "blocked force": ("try a softer blocking plane (SolveOptions.contact_stiffness_n_per_mm), "
                      "a gap under the tip (gap_mm) or a finer mesh at the tip"),
}


def _sets_touching(model: Model, nodes: np.ndarray) -> list[str]:
    """Named boundaries (facet sets) that contain any of the scalar dofs ``nodes``."""
    return [name for name, dofs in model.facet_dofs.items()
            if np.isin(nodes, dofs.ravel()).any()]


def _describe(model: Model, nodes: np.ndarray, what: str) -> str:
    x = model.X[nodes, 0]
    sets = _sets_touching(model, nodes)
    where = f"x = {x.min():.1f} to {x.max():.1f} mm" if np.ptp(x) > 0.05 else f"x = {x.min():.1f} mm"
    on = f" (touching {', '.join(sets)})" if sets else " (inside the body)"
    return f"{what} at {where}{on}"


def locate(model: Model, u: np.ndarray, residual: np.ndarray | None,
           inverted: np.ndarray) -> str:
    """Where in the (reference) body a failed solve went wrong."""
    if inverted.size:
        nodes = np.unique(model.edofs[inverted])
        return _describe(model, nodes, f"{inverted.size} tetrahedra inverted")
    if residual is None or not np.all(np.isfinite(residual)):
        return "no finite residual to locate"
    return _concentration(model, residual, "residual") or "no residual left"


def _concentration(model: Model, field: np.ndarray, what: str) -> str | None:
    """The nodes holding 90% of a nodal vector field's |.|^2 (free nodes), and its largest."""
    r = np.linalg.norm(field.reshape(-1, 3), axis=1)
    r[~np.isin(np.arange(r.size), model.free // 3)] = 0.0
    if not r.any():
        return None
    order = np.argsort(r)[::-1]
    share = np.cumsum(r[order] ** 2) / float(np.sum(r ** 2))
    top = order[: int(np.searchsorted(share, 0.9)) + 1]
    worst = model.X[order[0]]
    return (_describe(model, top, f"90% of the {what}") + "; largest at "
            f"({worst[0]:.1f}, {worst[1]:.1f}, {worst[2]:.1f}) mm")


def softest_mode(newton, u: np.ndarray, load, iterations: int = 8) -> str:
    """Where the tangent at ``u`` is softest: inverse iteration (one factorisation, ``iterations``
    back-substitutions) toward the eigenvector of the eigenvalue nearest zero, the shape in which
    the body gives way at a critical point; located as :func:`locate` locates a residual."""
    model = newton.model
    newton.factor(u, load)
    x = np.random.default_rng(0).standard_normal(model.free.size)
    for _ in range(iterations):
        x = newton.back_solve(x)
        x /= np.linalg.norm(x)
    mode = np.zeros(model.ndof)
    mode[model.free] = x
    return _concentration(model, mode, "softest mode") or "no free nodes"


def message(stage: str, load: str, why: str, region: str) -> str:
    """One sentence a person can act on."""
    return f"{stage} stage failed at {load}: {why}; where: {region}; try: {HINTS[stage]}"
