"""Material constants for solvers without Yeoh: neo-Hookean and a fitted Mooney-Rivlin.

- **neo-Hookean, small-strain equivalent**: the same initial shear modulus as the Yeoh
  material, mu = 2 C10 (C10 = mu/2), and the same bulk modulus K (D1 = 2/K); Young's
  modulus E = 9 K mu / (3 K + mu), Poisson's ratio (3K - 2mu) / (2(3K + mu)). It lacks the
  stiffening of C20, C30, so it is softer than the Yeoh body at large stretch.
- **Mooney-Rivlin, fitted**: C10, C01 by linear least squares to the Yeoh material's
  incompressible nominal stress in three homogeneous modes -- uniaxial tension, planar
  (pure shear) and equibiaxial tension -- at 50 stretches each, evenly spaced over the
  design's working range 1 < lambda <= lambda_max, each mode scaled by its largest Yeoh
  stress so the three weigh alike. lambda_max is the largest principal stretch of the
  design's FE curve (the build's ``report.json``), else :data:`DEFAULT_MAX_STRETCH`.

Nominal stresses (incompressible, W1 = dW/dI1, W2 = dW/dI2)::

    uniaxial     P = 2 (l - l^-2) (W1 + W2 / l)
    planar       P = 2 (l - l^-3) (W1 + W2)
    equibiaxial  P = 2 (l - l^-5) (W1 + l^2 W2)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pnmold.errors import UsageError
from pnmold.fem import Membrane, Yeoh

#: the working range's top when the design's FE curve is not known
DEFAULT_MAX_STRETCH = 2.0
MODES = ("uniaxial", "planar", "equibiaxial")
_SAMPLES = 50


def _invariants(mode: str, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(I1, I2, factor, k2): nominal stress = factor * (W1 + k2 * W2)."""
    if mode == "uniaxial":
        return lam ** 2 + 2 / lam, 2 * lam + lam ** -2, 2 * (lam - lam ** -2), 1 / lam
    if mode == "planar":
        i = lam ** 2 + 1 + lam ** -2
        return i, i, 2 * (lam - lam ** -3), np.ones_like(lam)
    if mode == "equibiaxial":
        return 2 * lam ** 2 + lam ** -4, lam ** 4 + 2 * lam ** -2, 2 * (lam - lam ** -5), lam ** 2
    raise UsageError(f"mode: one of {', '.join(MODES)}, got {mode!r}")


def yeoh_nominal_stress(material: Yeoh, mode: str, lam: np.ndarray) -> np.ndarray:
    """The incompressible Yeoh material's nominal stress (MPa) in ``mode`` at stretches ``lam``."""
    lam = np.asarray(lam, float)
    i1, _, factor, _ = _invariants(mode, lam)
    x = i1 - 3
    return factor * (material.c10_mpa + 2 * material.c20_mpa * x + 3 * material.c30_mpa * x ** 2)


def mooney_rivlin_nominal_stress(c10_mpa: float, c01_mpa: float, mode: str, lam: np.ndarray) -> np.ndarray:
    """The incompressible Mooney-Rivlin material's nominal stress (MPa)."""
    lam = np.asarray(lam, float)
    _, _, factor, k2 = _invariants(mode, lam)
    return factor * (c10_mpa + k2 * c01_mpa)


def fit_mooney_rivlin(material: Yeoh, max_stretch: float) -> dict[str, Any]:
    """C10, C01 (MPa) fitted to ``material`` over 1 < lambda <= ``max_stretch`` (module doc)."""
    if not max_stretch > 1.0:
        raise UsageError(f"the working range needs a largest stretch > 1, got {max_stretch:g}")
    lam = np.linspace(1.0, max_stretch, _SAMPLES + 1)[1:]
    rows, rhs, scales = [], [], {}
    for mode in MODES:
        _, _, factor, k2 = _invariants(mode, lam)
        target = yeoh_nominal_stress(material, mode, lam)
        scale = float(np.abs(target).max())
        scales[mode] = scale
        rows.append(np.column_stack([factor, factor * k2]) / scale)
        rhs.append(target / scale)
    (c10, c01), *_ = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)
    errors = {m: float(np.abs(mooney_rivlin_nominal_stress(c10, c01, m, lam)
                              - yeoh_nominal_stress(material, m, lam)).max() / scales[m]) for m in MODES}
    return {"c10_mpa": float(c10), "c01_mpa": float(c01), "stretch_range": [1.0, float(max_stretch)],
            "initial_shear_modulus_mpa": float(2 * (c10 + c01)),
            "max_error_fraction": {m: round(e, 5) for m, e in errors.items()},
            "method": (f"linear least squares to the Yeoh nominal stress, incompressible uniaxial, planar and "
                       f"equibiaxial modes, {_SAMPLES} stretches each on (1, {max_stretch:.4g}], each mode scaled "
                       "by its largest stress; max_error_fraction: largest misfit / that scale")}


def material_constants(material: Yeoh, membrane: Membrane | None, *, max_stretch: float | None = None,
                       stretch_source: str | None = None) -> dict[str, Any]:
    """``material.json``: the Yeoh constants as exported, their neo-Hookean small-strain
    equivalent, a fitted Mooney-Rivlin, the density and the paper (mm, N, MPa, tonne, s)."""
    mu, k = material.shear_modulus_mpa, material.bulk_modulus_mpa
    top = float(max_stretch) if max_stretch else DEFAULT_MAX_STRETCH
    mr = fit_mooney_rivlin(material, top)
    mr["d1_per_mpa"] = 2.0 / k
    mr["stretch_source"] = stretch_source or f"assumed (no FE curve): {DEFAULT_MAX_STRETCH:g}"
    doc: dict[str, Any] = {
        "schema": "pnmold.material/1",
        "units": "mm, N, MPa, tonne, s (densities also in g/mL)",
        "yeoh": {"c10_mpa": material.c10_mpa, "c20_mpa": material.c20_mpa, "c30_mpa": material.c30_mpa,
                 "d1_per_mpa": 2.0 / k, "d2_per_mpa": 0.0, "d3_per_mpa": 0.0, "bulk_modulus_mpa": k,
                 "bulk_ratio": material.bulk_ratio,
                 "volumetric": "U = (K/2)(J - 1)^2; pnmold applies it to each element's mean dilatation"},
        "neo_hookean": {"mu_mpa": mu, "c10_mpa": mu / 2.0, "d1_per_mpa": 2.0 / k, "bulk_modulus_mpa": k,
                        "youngs_modulus_mpa": 9 * k * mu / (3 * k + mu),
                        "poisson": (3 * k - 2 * mu) / (2 * (3 * k + mu)),
                        "method": "small-strain equivalent: mu = 2 C10, the same K; no stiffening"},
        "mooney_rivlin": mr,
        "density_g_per_ml": material.density_g_per_ml,
        "density_tonne_per_mm3": material.density_g_per_ml * 1e-9,
    }
    if membrane is not None:
        doc["paper"] = {"modulus_mpa": membrane.modulus_mpa, "poisson": membrane.poisson,
                        "thickness_mm": membrane.thickness_mm, "stiffness_n_per_mm": membrane.stiffness_n_per_mm,
                        "model": "St.Venant-Kirchhoff membrane on the strain_limiting_layer facets"}
    return doc
