"""Materials of the FE model: the Yeoh elastomer and the strain-limiting membrane.

Elastomer
---------
Strain energy per reference volume (supplement eq. 1, Abaqus Yeoh N = 3)::

    W = C10 (I1b - 3) + C20 (I1b - 3)^2 + C30 (I1b - 3)^3 + U(J),   I1b = J^(-2/3) tr(F^T F)

The supplement uses D_i = 0 (incompressible, Abaqus C3D10H hybrid elements). We use
quadratic tetrahedra (P2) with a *penalty* U = K/2 (theta - 1)^2 and, by default,
``volumetric="mean_dilatation"``: theta is the volume ratio of each element (current over
reference volume), i.e. the P2/P0 mixed element with its constant pressure condensed
element by element (Simo-Taylor-Pister). That imposes one volume constraint per tet
instead of one per quadrature point (four), so it does not lock, and the unknowns and
the solver stay displacement-only (symmetric, no saddle point). ``volumetric="penalty"``
(U evaluated at each quadrature point) is kept for comparison; it locks as K grows
(docs/fe.md: with K = 1000 mu it collapsed).

Default ``bulk_ratio`` K/mu = 200 (Poisson's ratio 0.4975). On the test beam (1 mm
walls, 20 kPa) the tip moves 3.7% between K/mu = 200 and 1000 and 18% between 50 and
1000 (``test_fem.py::test_bulk_ratio_sensitivity``); larger K costs Newton iterations
(each linearised step over a rotation phi carries a spurious volume change ~ phi^2, so
a stress ~ K phi^2): on an fPN body K/mu = 50 needed a third fewer factorisations than 200.
The uniaxial and cylinder verifications use K/mu = 5000 against the incompressible
closed forms.

Membrane
--------
The paper sheet is a large-deformation St.Venant-Kirchhoff membrane (plane stress, Green
-Lagrange strain) on the ``strain_limiting_layer`` facets: stretching stiffness E*t is
exact and it adds no bending stiffness (the supplement's STRI65 shells add a tiny one).

Compression is relaxed (``wrinkles=True``, :mod:`.surface`): a 0.1 mm sheet bonded to
rubber cannot carry more compression than its wrinkling load. A stiff film on a compliant
half-space wrinkles at the strain ``eps_c = 1/4 (3 Es / Ef)^(2/3)`` (plane-strain moduli;
Chen & Hutchinson, J. Appl. Mech. 71:597, 2004; Huang, Hong & Suo, JMPS 53:2101, 2005):
for 6.5 GPa paper on Elastosil M4601 (Es = 8 C10 = 0.88 MPa) 1.3e-3, on Ecoflex 00-30
(0.065 MPa) 2.4e-4. Beyond it the sheet buckles out of plane with a wavelength of
1-2 cm and its compressive force stays near ``Ef t eps_c`` (0.9 and 0.16 N/mm). A
membrane without bending stiffness has no such limit: pressed further, it buckles at the
scale of the elements instead, a mesh-dependent instability -- the Ecoflex stalls seen
before it (0.94/1.40/2.23 kPa on three meshes) had half the sheet in compression, down to
-0.68 N/mm, with negative pivots. The relaxed sheet keeps E*t in tension (the strain
limit is unchanged) and holds compression at the wrinkling force. The half-space formula
is an estimate (assumed: the sheet is embedded, rubber on both sides of finite
thickness, which moves eps_c by a factor of order one); ``wrinkles=False`` restores the
plain St.Venant-Kirchhoff sheet.

The sheet's stretching stiffness is *solved* in series with ``contrast`` times the
substrate's small-strain modulus (:meth:`Membrane.solved_on`; default 1000, assumed): E_solved
= 1 / (1/E + 1/(1000 x 6 C10)), 599 MPa for the 6.5 GPa paper on Elastosil M4601, 48.6 MPa on
Ecoflex 00-30. The paper is practically inextensible either way -- its strain stays near
1/1000 of the rubber's -- but the 6.5 GPa sheet on a 0.05 MPa rubber (a contrast of 1e5)
leaves Newton a tangent whose sheet terms swamp the rubber's: the sPN's curve stalled at
49.1 kPa and the Ecoflex fPN's at 1.2 kPa with it, and both solve with the series sheet. What it
costs, measured on the fPN (chambers up, build mesh): full bend 47.95 kPa
with the 6.5 GPa sheet, 47.60 kPa solved in series (-0.7%); on the 4 mm hollow test beam at
40 kPa the tip moves 1.3% of its travel between contrast 1000 and 4000 and 0.4% between 4000
and 16000 (``test_fem_path.py::test_sheet_contrast_barely_moves_the_bend``). A compliance added
to the layer (the ``layer_compliance`` effect) still acts in series, so the FE sees every
change of it. The wrinkling force is the physical sheet's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..errors import DesignError
from ..materials.library import ELASTOSIL

#: Mass density to force density: 1 g/mL under 1 g, in N/mm^3.
G_STANDARD_N_PER_MM3_PER_G_PER_ML = 9.80665e-6

VOLUMETRIC_TREATMENTS = ("mean_dilatation", "penalty")


@dataclass(frozen=True)
class Yeoh:
    """Nearly incompressible Yeoh elastomer (defaults: Elastosil M4601).

    Parameters
    ----------
    c10_mpa, c20_mpa, c30_mpa : Yeoh constants (default: the library's Elastosil M4601).
    density_g_per_ml : mass density (g/mL).
    bulk_ratio : K / mu of the volumetric penalty, mu = 2 C10.
    volumetric : ``"mean_dilatation"`` (P2/P0, default) or ``"penalty"`` (pointwise).
    stretch_at_break : 1 + the elongation at break; a curve ends where the largest
        principal stretch passes it (None: no such stop).
    """

    c10_mpa: float = ELASTOSIL.c10_mpa
    c20_mpa: float = ELASTOSIL.c20_mpa
    c30_mpa: float = ELASTOSIL.c30_mpa
    density_g_per_ml: float = ELASTOSIL.density_g_per_ml
    bulk_ratio: float = 200.0
    volumetric: str = "mean_dilatation"
    stretch_at_break: float | None = None

    def __post_init__(self) -> None:
        if not self.c10_mpa > 0:
            raise DesignError("c10_mpa", f"must be > 0, got {self.c10_mpa}")
        if self.c20_mpa < 0 or self.c30_mpa < 0:
            raise DesignError("c20_mpa", "C20 and C30 must be >= 0 (stable for all stretches)")
        if self.density_g_per_ml < 0:
            raise DesignError("density_g_per_ml", f"must be >= 0, got {self.density_g_per_ml}")
        if not self.bulk_ratio > 1:
            raise DesignError("bulk_ratio", f"K/mu must be > 1, got {self.bulk_ratio}")
        if self.stretch_at_break is not None and not self.stretch_at_break > 1:
            raise DesignError("stretch_at_break", f"must be > 1, got {self.stretch_at_break}")
        if self.volumetric not in VOLUMETRIC_TREATMENTS:
            raise DesignError("volumetric", f"one of {VOLUMETRIC_TREATMENTS}, "
                              f"got {self.volumetric!r}")

    @property
    def shear_modulus_mpa(self) -> float:
        """Initial shear modulus mu = 2 C10."""
        return 2.0 * self.c10_mpa

    @property
    def bulk_modulus_mpa(self) -> float:
        """Penalty bulk modulus K = bulk_ratio * mu."""
        return self.bulk_ratio * self.shear_modulus_mpa

    @property
    def youngs_modulus_mpa(self) -> float:
        """Small-strain Young's modulus 9 K mu / (3 K + mu) (-> 6 C10 as K -> inf)."""
        mu, k = self.shear_modulus_mpa, self.bulk_modulus_mpa
        return 9.0 * k * mu / (3.0 * k + mu)

    @property
    def weight_density_n_per_mm3(self) -> float:
        """Weight per volume under standard gravity."""
        return self.density_g_per_ml * G_STANDARD_N_PER_MM3_PER_G_PER_ML


@dataclass(frozen=True)
class Membrane:
    """Linear-elastic (St.Venant-Kirchhoff) membrane; defaults: the paper sheet.

    Parameters
    ----------
    modulus_mpa : Young's modulus (supplement: 6.5 GPa).
    poisson : Poisson's ratio (supplement: 0.2).
    thickness_mm : sheet thickness (0.1 mm).
    wrinkles : compression beyond the wrinkling strain on ``substrate`` is relaxed
        (see the module notes); False for the plain St.Venant-Kirchhoff sheet.
    wrinkling_strain : the compressive strain at which the sheet wrinkles; None: the
        half-space estimate on the elastomer (:meth:`wrinkling_strain_on`).
    contrast : the solve carries the sheet's stiffness in series with this many times the
        substrate's modulus (:meth:`solved_on`; assumed, see the module notes); None: E as
        given.
    """

    modulus_mpa: float = 6500.0
    poisson: float = 0.2
    thickness_mm: float = 0.1
    wrinkles: bool = True
    wrinkling_strain: float | None = None
    contrast: float | None = 1000.0

    def __post_init__(self) -> None:
        if not self.modulus_mpa > 0:
            raise DesignError("modulus_mpa", f"must be > 0, got {self.modulus_mpa}")
        if not -1.0 < self.poisson < 0.5:
            raise DesignError("poisson", f"must be in (-1, 0.5), got {self.poisson}")
        if not self.thickness_mm > 0:
            raise DesignError("thickness_mm", f"must be > 0, got {self.thickness_mm}")
        if self.wrinkling_strain is not None and self.wrinkling_strain < 0:
            raise DesignError("wrinkling_strain", f"must be >= 0, got {self.wrinkling_strain}")
        if self.contrast is not None and not self.contrast > 0:
            raise DesignError("contrast", f"must be > 0 or None, got {self.contrast}")

    @property
    def stiffness_n_per_mm(self) -> float:
        """Stretching stiffness E * t."""
        return self.modulus_mpa * self.thickness_mm

    @property
    def plane_stress_stiffness_n_per_mm(self) -> float:
        """E t / (1 - nu^2), the sheet's biaxial stiffness."""
        return self.stiffness_n_per_mm / (1.0 - self.poisson ** 2)

    def wrinkling_strain_on(self, substrate: Yeoh) -> float:
        """Compressive strain at which the sheet wrinkles on ``substrate``: the given
        ``wrinkling_strain``, or the half-space estimate ``1/4 (3 Es / Ef)^(2/3)``
        (plane-strain moduli; Es = 8 C10 for an incompressible rubber)."""
        if self.wrinkling_strain is not None:
            return self.wrinkling_strain
        es = 8.0 * substrate.c10_mpa
        ef = self.modulus_mpa / (1.0 - self.poisson ** 2)
        return 0.25 * (3.0 * es / ef) ** (2.0 / 3.0)

    def solved_on(self, substrate: Yeoh) -> Membrane:
        """The sheet as the solve carries it on ``substrate``: Young's modulus in series with
        ``contrast`` x 6 C10 (module notes), the wrinkling strain that keeps the physical
        sheet's wrinkling force; itself when ``contrast`` is None."""
        if self.contrast is None:
            return self
        cap = self.contrast * 6.0 * substrate.c10_mpa
        solved = 1.0 / (1.0 / self.modulus_mpa + 1.0 / cap)
        strain = self.wrinkling_strain_on(substrate) * self.modulus_mpa / solved
        return replace(self, modulus_mpa=solved, wrinkling_strain=strain, contrast=None)

    def wrinkling_force_n_per_mm(self, substrate: Yeoh) -> float:
        """The compressive membrane force the sheet holds once wrinkled (N/mm)."""
        return self.plane_stress_stiffness_n_per_mm * self.wrinkling_strain_on(substrate)
