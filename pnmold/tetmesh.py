"""The plain mesh values: the element sizes asked of ``mesh`` (gmsh), the mesh it hands to ``fem``.

No gmsh state: numpy arrays and names only. Boundary names are the contract between
CAD, mesh and FE (see :data:`BOUNDARY_NAMES`); face indices never are.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Named facet sets a TetMesh of an actuator carries.
CAVITY = "cavity"  # every face of the chambers, the channel and the inlet bore
CLAMP = "clamp"  # top and bottom faces up to the clamp's end (the proximal chamber's; zero displacement)
STRAIN_LIMITING_LAYER = "strain_limiting_layer"  # bottom-face facets under the paper sheet
FREE_END = "free_end"  # the distal end face (x = L), for the bend angle
SYMMETRY = "symmetry"  # the y = 0 plane of a half model (u_y = 0)
BOUNDARY_NAMES = (CAVITY, CLAMP, STRAIN_LIMITING_LAYER, FREE_END, SYMMETRY)

#: Named element sets.
ELASTOMER = "elastomer"  # every element
BOTTOM_LAYER = "bottom_layer"  # the strain-limiting layer's elements, when it is a rubber of its own


@dataclass(frozen=True)
class MeshSize:
    """Element sizes (mm) of the linear tets that carry quadratic (P2) fields.

    ``wall_mm`` applies within ``band_mm`` of the cavity (the thin walls), growing to
    ``max_mm`` farther away (bottom layer, end wall). The defaults give about one
    quadratic element across a 1 mm wall; the full-bend pressure of the fPN moved 0.5%
    when refined to 2/4 mm (benchmarks/fem.py prints the tip at a reference pressure).
    """

    wall_mm: float = 2.5
    max_mm: float = 5.0
    band_mm: float = 1.0
    half: bool = True

    def refined(self, factor: float) -> MeshSize:
        return MeshSize(self.wall_mm / factor, self.max_mm / factor, self.band_mm, self.half)


@dataclass(frozen=True, eq=False)
class TetMesh:
    """Linear (4-node) tetrahedra with named facet sets; lengths in mm.

    Attributes
    ----------
    nodes_mm : (N, 3) float array of node coordinates in the actuator frame.
    tets : (M, 4) int array of node indices, positively oriented.
    facets : name -> (K, 3) int array of boundary triangles (node indices), oriented
        with the outward normal of the solid.
    regions : name -> (M_k,) int array of element indices.
    tip_mm : the tip point (free end, bottom face, y = 0) in the reference frame.
    half : True when only y >= 0 is meshed (the y = 0 plane is ``symmetry``).
    """

    nodes_mm: np.ndarray
    tets: np.ndarray
    facets: dict[str, np.ndarray] = field(default_factory=dict)
    regions: dict[str, np.ndarray] = field(default_factory=dict)
    tip_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    half: bool = False

    @property
    def n_nodes(self) -> int:
        return int(self.nodes_mm.shape[0])

    @property
    def n_tets(self) -> int:
        return int(self.tets.shape[0])

    def volume_mm3(self) -> float:
        """Total volume of the tetrahedra (of the half model when ``half``)."""
        p = self.nodes_mm[self.tets]
        d = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]),
                      p[:, 3] - p[:, 0])
        return float(np.sum(d) / 6.0)
