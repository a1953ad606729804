"""How the catalogued effects (docs/effects.md) enter the reduced model's free law.

Strain stiffening raises the pressure a deformation needs by a factor ``r`` (``p = p_eff r(p_eff)``),
read from the FE's own run with stiffer rubber or, without it, from the Yeoh slopes; a layer
compliance makes the shape (and the volume) read the law at a raised pressure, by the share of the
bottom's stretching stiffness the layer loses; self-contact alike, by the FE's own run with its walls
kept apart; gravity is the orientation's in-plane part. The FE's variant runs become
:class:`pnmold.physics.response.Response` factors (:func:`variant_responses`). Pure functions of the
design and the free law (:mod:`.rom_law`); the model that applies them: docs/reduced-model.md, the frame
of the gravity: docs/frame-and-units.md.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pnmold.conventions import gravity_direction
from pnmold.design import Design
from pnmold.physics.characterisation import Characterisation, distinct_steps
from pnmold.physics.response import Response, responses, solve_stiffened
from pnmold.physics.rom_law import Tables, interp

#: strain of the rubber that carries the bend, as a fraction of the FE's peak principal strain
#: (equibiaxial): fitted to the FE with Yeoh C20 + 0.05 MPa (fPN, coarse mesh), whose pressure
#: for a given bend rose 1, 4 and 8 % at 11, 23 and 34 kPa (``benchmarks/rom.py --fe-effects``);
#: the peak strain itself (fraction 1) would have predicted 10 times that
REPRESENTATIVE_STRAIN = 0.12
#: layer compliance: gain and strain scale of the lost stiffness share (see :func:`layer_softening`)
LAYER_SHARE_GAIN, LAYER_STRAIN_SCALE = 0.75, 0.2


def variant_responses(design: Design, c: Characterisation, tables: Tables) -> dict[str, dict[str, Response]]:
    """effect -> {"bend", "volume", "length": Response} from the FE's variant runs of ``c`` (the layer
    compliance's by the stiffness share it loses, the strain stiffening's by its dC20)."""
    k = distinct_steps(c.pressure_kpa)
    base = {"pressure_kpa": tables.p, "bend_angle_deg": c.bend_angle_deg[k],
            "cavity_volume_ml": tables.volume_ml, "tip_x_mm": c.tip_x_mm[k], "tip_z_mm": c.tip_z_mm[k],
            "clamp_x_mm": design.clamp_end_mm}
    out = {}
    layer = c.variant_runs("layer_compliance")
    if layer:
        out["layer_compliance"] = responses(
            base, [(layer_share(design, r["value"]), r) for r in layer], softening=True)
    stiff = c.variant_runs("strain_stiffening")
    if stiff:
        out["strain_stiffening"] = responses(base, [(r["value"], r) for r in stiff], softening=False)
    contact = c.variant_runs("self_contact")
    if contact:
        out["self_contact"] = responses(base, [(r["value"], r) for r in contact], softening=True)
    return out


def layer_share(design: Design, compliance_mm_per_n: float) -> float:
    """The share of the bottom's stretching stiffness (N/mm) an added layer compliance c loses. With
    paper: k_r/(k_p' + k_r) - k_r/(k_p + k_r), k_p = E t the paper's, k_p' = 1/(1/k_p + c), k_r = 6 C10
    x thickness the bottom rubber's; without: the rubber limits the strain alone, 1 - k_r'/k_r."""
    d = design
    rubber = 6.0 * d.bottom_material.c10_mpa * d.bottom_layer.thickness_mm
    if not d.paper.present:
        return 1.0 - 1.0 / (1.0 + compliance_mm_per_n * rubber)
    paper = d.paper.modulus_mpa * d.paper.thickness_mm
    return rubber / (1.0 / (1.0 / paper + compliance_mm_per_n) + rubber) - rubber / (paper + rubber)


def layer_compliance(design: Design, tables: Tables, down: bool, compliance_mm_per_n: float, soft: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The hinges' compliance table under the weight (the chambers-down one when ``down``) and the factor
    it is read with. With a compliant layer and the FE's probe of that orientation with one
    (:func:`pnmold.physics.probes.layer_probe`): the probe's compliance, in proportion to the share of the
    bottom's stiffness lost, read as it is (the layer carries the weight's moment); else the table, grown
    by the bend's factor ``soft``."""
    compliance = tables.compliance_down if down else tables.compliance
    probed = tables.compliance_down_layer if down else tables.compliance_layer
    if compliance_mm_per_n <= 0 or probed is None:
        return compliance, soft
    w = layer_share(design, compliance_mm_per_n) / layer_share(design, tables.layer_mm_per_n)
    return compliance + w * (probed - compliance), np.ones_like(soft)


def layer_softening(design: Design, tables: Tables, response: Mapping[str, Response] | None,
                    compliance_mm_per_n: float, p_eff: Mapping[str, np.ndarray]
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Factors on the pressure the shape and the volume read with an added layer compliance, and
    the stretch of the free part.

    From the FE variants (``response``, :mod:`.response`), the lost stiffness share as the intensity.
    Without a variant: the shape's factor 1 + share x B, B = 0.75 / (1 + e/0.2) with e the FE's peak
    strain (fitted to the FE: fPN, coarse mesh, c = 0.3 and 1 mm/N at 5-23 kPa: 6-24 % more pressure-
    equivalent bend, the same tip path and volume), the volume's factor and the stretch 1."""
    share = layer_share(design, compliance_mm_per_n)
    if response is not None:
        return (response["bend"](p_eff["bend"], share), response["volume"](p_eff["volume"], share),
                response["length"](p_eff["bend"], share))
    strain = np.maximum(interp(tables.p, tables.stretch, np.maximum(p_eff["bend"], 0.0)) - 1.0, 0.0)
    return 1.0 + share * LAYER_SHARE_GAIN / (1.0 + strain / LAYER_STRAIN_SCALE), 1.0, 1.0


def stiffening(design: Design, tables: Tables, response: Mapping[str, Response] | None, p_m: np.ndarray,
               dc20: float, dc30: float) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray | float]:
    """p_eff of the shape and of the volume (``{"bend": .., "volume": ..}``) with p_m = p_eff r(p_eff),
    the shape's r there, and the stretch of the free part.

    From the FE variants (``response``, :mod:`.response`) with intensity dC20 + 1.5 dC30 I1 (MPa): the
    added Yeoh slope dW/dI1 / (2 I1) at the representative stretch, the variants' dC20 at C30 = 0.
    Without a variant r is the ratio of the slopes themselves, alike for shape and volume."""
    if not (dc20 or dc30):
        return {"bend": p_m, "volume": p_m}, np.ones_like(p_m), 1.0
    m = design.material

    def i1(p):
        peak = np.maximum(interp(tables.p, tables.stretch, np.maximum(p, 0.0)), 1.0)
        lam = 1.0 + REPRESENTATIVE_STRAIN * (peak - 1.0)
        return 2 * lam ** 2 + lam ** -4 - 3.0

    if response is None:
        def ratio(p):
            base = m.c10_mpa + 2 * m.c20_mpa * i1(p) + 3 * m.c30_mpa * i1(p) ** 2
            return 1.0 + (2 * dc20 * i1(p) + 3 * dc30 * i1(p) ** 2) / base

        q = solve_stiffened(p_m, ratio)
        return {"bend": q, "volume": q}, ratio(q), 1.0

    def intensity(p):
        return dc20 + 1.5 * dc30 * i1(p)

    q = {key: solve_stiffened(p_m, lambda x, f=response[key]: f(x, intensity(x))) for key in ("bend", "volume")}
    s = intensity(q["bend"])
    return q, response["bend"](q["bend"], s), response["length"](q["bend"], s)


def self_contact(response: Mapping[str, Response], end_kpa: float, share: float, p_bend: np.ndarray,
                 p_vol: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Self-contact read from the FE's own free run with it on (:func:`variant_responses`): the shape and
    the volume read the free law at the pressure where the nominal reaches the contact run's bend (and
    volume), ``share`` of the way (1: the FE's contact as solved). Returns the two pressures, the free
    part's stretch and, per row, the share of its pressure past the contact run's end ``end_kpa`` (its
    tip met the base, or another named stop: out of reach there, as past any FE's last solved step;
    the row is read at that end)."""
    excess = np.where(p_bend > end_kpa * (1.0 + 1e-9), 1.0 - end_kpa / np.maximum(p_bend, end_kpa), 0.0)
    at = np.minimum(p_bend, end_kpa)
    at_v = np.minimum(p_vol, end_kpa)
    return (at * response["bend"](at, share), at_v * response["volume"](at_v, share),
            response["length"](at, share), excess)


def contact_compliance(tables: Tables, down: bool, share: float, compliance: np.ndarray) -> np.ndarray:
    """The hinges' compliance table under the weight with self-contact: ``compliance`` (the one without it,
    any layer's change applied) moved ``share`` of the way by the change the FE's probe of that orientation
    with self-contact found (:func:`pnmold.physics.probes.contact_probe`): a weight that closes the gaps
    presses their walls together. Without that probe, as it is (assumed: the free run's contact alone)."""
    probed = tables.compliance_down_contact if down else tables.compliance_contact
    if share <= 0 or probed is None:
        return compliance
    return compliance + share * (probed - (tables.compliance_down if down else tables.compliance))


def gravity_xz(design: Design, orientation: str, g: float, density_scale: float = 1.0) -> tuple[float, float]:
    """The in-plane (x, z) weight of the orientation per unit of the design's rubber weight, in g (out of
    plane: none). ``density_scale``: the batch's density over the design's; submerged, the water's
    buoyancy is taken from the batch's own weight (net ``s - rho_water / rho`` of the design's weight)."""
    direction = gravity_direction(orientation, design.material.density_g_per_ml * density_scale)
    if g == 0 or direction is None:
        return (0.0, 0.0)
    return (g * density_scale * direction[0], g * density_scale * direction[2])
