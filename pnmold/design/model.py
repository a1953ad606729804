"""The design of a PneuNet actuator and its molds: frozen dataclasses, units in names.

Defaults describe the supplement's fast PneuNet (fPN). Every number either cites its
source or says ``assumed``: the supplement (Mosadegh et al., Adv. Funct. Mater. 2014, SI)
gives the chamber height (10.5 mm), the channel height (1 mm), the inside walls (1 mm),
the Yeoh constants of Elastosil M4601, the paper's modulus and the 2 mm biopsy punch;
its Fig. S1 drawing dimensions are not in the text, so those sizes are assumptions,
chosen after the Soft Robotics Toolkit PneuNet and an fPN-like body (docs/fe.md).

Frame (docs/frame-and-units.md): x along the length from the inlet/clamped end (x = 0), y across
the width centred on 0, z = 0 at the bottom (paper) face, chambers toward +z. mm, MPa.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from pnmold.conventions import PART_NAMES
from pnmold.materials.library import ELASTOSIL

KINDS = ("fpn", "spn")


def _f(default, doc: str, source: str = "assumed"):
    """A design field with its documentation and the source of its default."""
    return field(default=default, metadata={"doc": doc, "source": source})


SUPPLEMENT = "Mosadegh et al. 2014, Supporting Information"


@dataclass(frozen=True)
class Meta:
    name: str = _f("fpn", "design name; names the output folder out/<name>/", "-")
    kind: str = _f("fpn", "fpn: each chamber has its own walls; spn: chambers share walls", "-")
    description: str = _f("", "one line shown by `pnmold templates`", "-")


@dataclass(frozen=True)
class Chambers:
    count: int = _f(11, "number of chambers", "assumed (an fPN-like body)")
    length_mm: float = _f(6.0, "cavity length along x", "assumed (SRT PneuNet 8 mm chamber incl. 1 mm walls)")
    width_mm: float = _f(16.0, "cavity width along y", "assumed (20 mm wide body, 2 mm side walls)")
    height_mm: float = _f(10.5, "cavity height along z, from the bottom layer", SUPPLEMENT + ": chambers 10.5 mm")
    inside_wall_mm: float = _f(1.0, "walls between chambers (normal to x)", SUPPLEMENT + ": 1 mm inside walls")
    outer_wall_mm: float = _f(
        2.0,
        "side walls and roof of each chamber",
        "assumed (thicker than inside walls so those expand)",
    )
    end_wall_mm: float = _f(
        4.0,
        "proximal end wall that holds the inlet bore",
        "assumed (room for the 2 mm punch and tube)",
    )
    tip_wall_mm: float = _f(
        0.0,
        "distal end wall at the tip; 0: as thick as the inside walls",
        "-",
    )
    gap_mm: float = _f(
        2.0,
        "fPN gap between neighbouring chambers (the exterior mold's plates); ignored for spn",
        "assumed (SRT PneuNet 2 mm spacing)",
    )


@dataclass(frozen=True)
class Channel:
    height_mm: float = _f(1.0, "connecting channel height", SUPPLEMENT + ": channel 1 mm high")
    width_mm: float = _f(2.0, "connecting channel width", "assumed (SRT PneuNet 2 x 2 mm channel)")


@dataclass(frozen=True)
class TopLayer:
    floor_mm: float = _f(
        2.0,
        "elastomer under the fPN gaps, around the channel",
        "assumed (1 mm over the 1 mm channel)",
    )


@dataclass(frozen=True)
class BottomLayer:
    thickness_mm: float = _f(2.0, "strain-limiting layer thickness (paper included)", "assumed")


@dataclass(frozen=True)
class PassiveSide:
    """The other side of a bidirectional segment: a second top layer, unpressurised, bonded under the
    bottom layer with its chambers facing it (the mirror image of the top layer about the bottom layer's
    mid-plane). It is cast in the top layer's own molds; its chambers are vented through their own
    punched inlet (assumed: open to the room while the other side is driven). The actuator then bends
    about a strain-limiting layer in its middle, and the passive side's ribs and roof resist the bend."""

    present: bool = _f(False, "a second, unpressurised top layer under the bottom layer (bidirectional segment)",
                       "-")


@dataclass(frozen=True)
class LayerMaterial:
    """The bottom (strain-limiting) layer's elastomer when it is not the top layer's: a stiffer
    rubber limits the strain alone, or together with the paper. Empty name: the same as
    ``[material]`` (and the constants stay 0); a library name fills in its constants."""

    name: str = _f("", "elastomer of the bottom (strain-limiting) layer; empty: [material]'s", "-")
    c10_mpa: float = _f(0.0, "Yeoh C10 (0 with an empty name)", "-")
    c20_mpa: float = _f(0.0, "Yeoh C20", "-")
    c30_mpa: float = _f(0.0, "Yeoh C30", "-")
    density_g_per_ml: float = _f(0.0, "density of the cured elastomer (0 with an empty name)", "-")
    mix_ratio_a_to_b: float = _f(0.0, "part A : part B by weight (0 with an empty name)", "-")


@dataclass(frozen=True)
class Paper:
    present: bool = _f(True, "a paper sheet limits the strain (false: the bottom layer's rubber alone)",
                       SUPPLEMENT + ": paper as the inextensible material")
    thickness_mm: float = _f(
        0.1,
        "paper sheet thickness; it lies on the mold floor (z = 0)",
        "assumed (80 g/m2 office paper)",
    )
    depth_mm: float = _f(
        0.0,
        "height of the sheet above the bottom face: 0 lays it on the mold floor (the supplement's); more "
        "embeds it, with that much rubber below it (poured first and cured) resisting the bend",
        "-",
    )
    inset_mm: float = _f(2.0, "margin from the paper's edge to the layer's edge", "assumed")
    modulus_mpa: float = _f(6500.0, "Young's modulus of the paper", SUPPLEMENT + ": E = 6.5 GPa")
    poisson: float = _f(0.2, "Poisson's ratio of the paper", SUPPLEMENT + ": nu = 0.2")


@dataclass(frozen=True)
class Clamp:
    """Where the actuator is held: the clamp fixes its top and bottom faces from x = 0 to ``length_mm``."""

    length_mm: float = _f(
        0.0,
        "length held by the clamp from the inlet end (x = 0); 0: the proximal chamber, as the supplement's FE",
        "-",
    )


@dataclass(frozen=True)
class Inlet:
    diameter_mm: float = _f(
        2.0,
        "inlet bore, punched along +x at x = 0 into the channel",
        SUPPLEMENT + ": 2 mm biopsy punch",
    )
    axis_offset_mm: float = _f(0.0, "height of the bore axis above the channel's centre line", "assumed")
    tubing_id_mm: float = _f(0.79375, "tubing inner diameter", SUPPLEMENT + ': 1/32" ID')
    tubing_od_mm: float = _f(
        2.38125,
        "tubing outer diameter (slightly larger than the bore seals it)",
        SUPPLEMENT + ': 3/32" OD',
    )


@dataclass(frozen=True)
class Mold:
    wall_mm: float = _f(3.0, "mold wall and floor thickness", "assumed")
    clearance_mm: float = _f(
        0.3,
        "gap where the interior mold's plate slides into the exterior mold",
        "assumed (FDM slide fit)",
    )
    pour_allowance_mm: float = _f(3.0, "extra wall height above the pour level for overflow", "assumed")
    plate_mm: float = _f(3.0, "thickness of the interior mold's base plate", "assumed")
    ledge_mm: float = _f(3.0, "registration shoulder the interior plate seats against", "assumed")
    seat_height_mm: float = _f(0.6, "height of the corner stops that locate the paper", "assumed (3 layers of 0.2 mm)")
    seat_width_mm: float = _f(1.0, "width of the corner stops' arms", "assumed")
    seat_arm_mm: float = _f(4.0, "length of the corner stops' arms along the paper edges", "assumed")


@dataclass(frozen=True)
class Material:
    """The elastomer; defaults: the library's Elastosil M4601 (the supplement's), with its sources."""

    name: str = _f(ELASTOSIL.name, "elastomer", ELASTOSIL.source("name"))
    c10_mpa: float = _f(ELASTOSIL.c10_mpa, "Yeoh C10", ELASTOSIL.source("c10_mpa"))
    c20_mpa: float = _f(ELASTOSIL.c20_mpa, "Yeoh C20", ELASTOSIL.source("c20_mpa"))
    c30_mpa: float = _f(ELASTOSIL.c30_mpa, "Yeoh C30", ELASTOSIL.source("c30_mpa"))
    density_g_per_ml: float = _f(ELASTOSIL.density_g_per_ml, "density of the cured elastomer",
                                 ELASTOSIL.source("density_g_per_ml"))
    mix_ratio_a_to_b: float = _f(ELASTOSIL.mix_ratio_a_to_b, "part A : part B by weight",
                                 ELASTOSIL.source("mix_ratio_a_to_b"))


@dataclass(frozen=True)
class Casting:
    min_elastomer_wall_mm: float = _f(
        0.8,
        "thinnest elastomer wall that casts reliably",
        "assumed (the supplement casts 1 mm walls)",
    )
    waste_margin: float = _f(0.15, "extra elastomer mixed beyond the cast volume (cups, overflow)", "assumed")


@dataclass(frozen=True)
class Printer:
    name: str = _f("Stratasys Dimension", "printer", SUPPLEMENT + ": Dimension 3D printer, ABS")
    build_x_mm: float = _f(203.0, "build volume x", "Stratasys Dimension spec: 203 x 203 x 305 mm")
    build_y_mm: float = _f(203.0, "build volume y", "Stratasys Dimension spec: 203 x 203 x 305 mm")
    build_z_mm: float = _f(305.0, "build volume z", "Stratasys Dimension spec: 203 x 203 x 305 mm")
    nozzle_mm: float = _f(0.4, "nozzle (extrusion width)", "assumed")
    min_wall_lines: int = _f(2, "fewest extrusion lines across a printed wall", "assumed")


SECTIONS = {
    "design": Meta, "chambers": Chambers, "channel": Channel, "top_layer": TopLayer,
    "bottom_layer": BottomLayer, "passive_side": PassiveSide, "paper": Paper, "clamp": Clamp, "inlet": Inlet,
    "mold": Mold,
    "material": Material, "layer_material": LayerMaterial, "casting": Casting, "printer": Printer,
}


@dataclass(frozen=True)
class Design:
    """A whole design. Derived sizes are properties so they cannot go stale."""

    design: Meta = field(default_factory=Meta)
    chambers: Chambers = field(default_factory=Chambers)
    channel: Channel = field(default_factory=Channel)
    top_layer: TopLayer = field(default_factory=TopLayer)
    bottom_layer: BottomLayer = field(default_factory=BottomLayer)
    passive_side: PassiveSide = field(default_factory=PassiveSide)
    paper: Paper = field(default_factory=Paper)
    clamp: Clamp = field(default_factory=Clamp)
    inlet: Inlet = field(default_factory=Inlet)
    mold: Mold = field(default_factory=Mold)
    material: Material = field(default_factory=Material)
    layer_material: LayerMaterial = field(default_factory=LayerMaterial)
    casting: Casting = field(default_factory=Casting)
    printer: Printer = field(default_factory=Printer)
    #: where each value not at its default came from ("section.key" -> source): the design file, an
    #: override, the material library; written into design.toml, not part of the digest
    origins: tuple[tuple[str, str], ...] = field(default=(), compare=False, repr=False)

    # -- identity -----------------------------------------------------------------
    @property
    def name(self) -> str:
        return self.design.name

    @property
    def kind(self) -> str:
        return self.design.kind

    @property
    def bottom_material(self) -> Material:
        """The bottom layer's elastomer: ``[layer_material]``, else the top layer's ``[material]``."""
        m = self.layer_material
        if not m.name:
            return self.material
        return Material(m.name, m.c10_mpa, m.c20_mpa, m.c30_mpa, m.density_g_per_ml, m.mix_ratio_a_to_b)

    @property
    def part_names(self) -> tuple[str, ...]:
        """The parts a build exports (docs/json-schemas.md): no paper sheet in a design without one, a passive
        layer only in a design with a passive side."""
        absent = {"paper": not self.paper.present, "passive_layer": not self.passive_side.present}
        return tuple(n for n in PART_NAMES if not absent.get(n, False))

    def replace(self, section: str, **changes) -> Design:
        """A new design with fields of one section changed (no mutation)."""
        return dataclasses.replace(self, **{section: dataclasses.replace(getattr(self, section), **changes)})

    # -- x layout -------------------------------------------------------------------
    @property
    def gap_mm(self) -> float:
        """Gap between neighbouring chambers: the plates of the exterior mold (0 for spn)."""
        return self.chambers.gap_mm if self.kind == "fpn" else 0.0

    @property
    def pitch_mm(self) -> float:
        c = self.chambers
        if self.kind == "fpn":
            return c.length_mm + 2 * c.inside_wall_mm + self.gap_mm
        return c.length_mm + c.inside_wall_mm

    def cavity_x_mm(self, i: int) -> tuple[float, float]:
        """x-extent of chamber ``i``'s cavity (0 = proximal)."""
        x0 = self.chambers.end_wall_mm + i * self.pitch_mm
        return x0, x0 + self.chambers.length_mm

    def gap_x_mm(self, i: int) -> tuple[float, float]:
        """x-extent of the fPN gap between chamber ``i`` and ``i + 1``."""
        x0 = self.cavity_x_mm(i)[1] + self.chambers.inside_wall_mm
        return x0, x0 + self.gap_mm

    @property
    def tip_wall_mm(self) -> float:
        """The distal end wall: ``chambers.tip_wall_mm``, or the inside walls' thickness when 0."""
        return self.chambers.tip_wall_mm or self.chambers.inside_wall_mm

    @property
    def length_mm(self) -> float:
        """Overall length L of the actuator (x)."""
        return self.cavity_x_mm(self.chambers.count - 1)[1] + self.tip_wall_mm

    @property
    def width_mm(self) -> float:
        """Overall width W of the actuator (y)."""
        return self.chambers.width_mm + 2 * self.chambers.outer_wall_mm

    # -- z layout -------------------------------------------------------------------
    @property
    def bottom_z0_mm(self) -> float:
        """Bottom face of the bottom layer: 0, or the passive side's height under it."""
        return self.top_height_mm if self.passive_side.present else 0.0

    @property
    def top_z0_mm(self) -> float:
        """Bottom face of the top layer = top face of the bottom layer."""
        return self.bottom_z0_mm + self.bottom_layer.thickness_mm

    @property
    def mid_plane_z_mm(self) -> float:
        """The bottom layer's mid-plane: the passive side is the top layer mirrored about it."""
        return (self.bottom_z0_mm + self.top_z0_mm) / 2

    @property
    def sheet_z_mm(self) -> float:
        """Height of the paper sheet's lower face: ``paper.depth_mm`` above the bottom layer's face."""
        return self.bottom_z0_mm + self.paper.depth_mm

    @property
    def top_height_mm(self) -> float:
        """Height of the top layer: cavity height plus roof."""
        return self.chambers.height_mm + self.chambers.outer_wall_mm

    @property
    def height_mm(self) -> float:
        """Overall height of the actuator (z)."""
        return self.top_z0_mm + self.top_height_mm

    # -- channel and inlet ------------------------------------------------------------
    @property
    def proximal_end_mm(self) -> float:
        """x where the proximal chamber (its cavity and distal wall) ends."""
        return self.cavity_x_mm(0)[1] + self.chambers.inside_wall_mm

    @property
    def clamp_end_mm(self) -> float:
        """x where the clamp ends: ``clamp.length_mm``, or the proximal chamber's end when 0 (supplement:
        "zero displacements at the top and bottom face of the proximal pneu-net chamber")."""
        return self.clamp.length_mm or self.proximal_end_mm

    @property
    def free_length_mm(self) -> float:
        """Length from the clamp's end to the tip: what bends."""
        return self.length_mm - self.clamp_end_mm

    @property
    def elastomer_volume_mm3(self) -> float:
        """Solid volume of the cast actuator: the envelope less the chambers, the channel and the
        fPN gaps (the inlet bore, about 0.1 % of it, and the paper are left out)."""
        c, ch = self.chambers, self.channel
        envelope = self.length_mm * self.width_mm * self.height_mm
        cavities = c.count * c.length_mm * c.width_mm * c.height_mm
        x0, x1 = self.channel_x_mm
        channel = (x1 - x0 - c.count * c.length_mm) * ch.width_mm * ch.height_mm
        gaps = (c.count - 1) * self.gap_mm * self.width_mm * (self.top_height_mm - self.top_layer.floor_mm)
        sides = 2 if self.passive_side.present else 1  # the passive side is a second top layer
        return envelope - sides * (cavities + channel + gaps)

    @property
    def elastomer_mass_g(self) -> float:
        """Mass of the cast actuator: the bottom slab of its own rubber (``bottom_material``), the rest
        of the top layer's (the paper's few tenths of a gram left out)."""
        slab_mm3 = self.length_mm * self.width_mm * self.bottom_layer.thickness_mm
        return ((self.elastomer_volume_mm3 - slab_mm3) * self.material.density_g_per_ml
                + slab_mm3 * self.bottom_material.density_g_per_ml) / 1000.0

    @property
    def channel_x_mm(self) -> tuple[float, float]:
        """The channel starts halfway into the end wall and ends in the last cavity."""
        return self.chambers.end_wall_mm / 2, self.cavity_x_mm(self.chambers.count - 1)[1]

    @property
    def chamber_boxes_mm(self) -> tuple[tuple[tuple[float, float], ...], ...]:
        """Each chamber's air cavity as its (x, y, z) ranges in mm, proximal first: the interior mold's
        cores, the cavities the mesh names ``cavity``."""
        c, z0 = self.chambers, self.top_z0_mm
        return tuple((self.cavity_x_mm(i), (-c.width_mm / 2, c.width_mm / 2), (z0, z0 + c.height_mm))
                     for i in range(c.count))

    @property
    def channel_box_mm(self) -> tuple[tuple[float, float], ...]:
        """The connecting channel's (x, y, z) ranges in mm."""
        w, z0 = self.channel.width_mm / 2, self.top_z0_mm
        return self.channel_x_mm, (-w, w), (z0, z0 + self.channel.height_mm)

    @property
    def inlet_axis_z_mm(self) -> float:
        return self.top_z0_mm + self.channel.height_mm / 2 + self.inlet.axis_offset_mm

    @property
    def inlet_depth_mm(self) -> float:
        """The punch goes in from x = 0 until its full bore has entered the channel."""
        return self.channel_x_mm[0] + self.inlet.diameter_mm / 2

    # -- paper and molds --------------------------------------------------------------
    @property
    def paper_size_mm(self) -> tuple[float, float]:
        """Paper cut size (x, y)."""
        return (self.length_mm - 2 * self.paper.inset_mm, self.width_mm - 2 * self.paper.inset_mm)

    @property
    def seat_top_mm(self) -> float:
        """Height of the corner stops that locate the paper: above its depth by ``mold.seat_height_mm``
        (0 without paper)."""
        return self.paper.depth_mm + self.mold.seat_height_mm if self.paper.present else 0.0

    @property
    def printable_wall_mm(self) -> float:
        """Thinnest wall the printer makes: nozzle width times the fewest lines."""
        return self.printer.nozzle_mm * self.printer.min_wall_lines

    @property
    def exterior_mold_size_mm(self) -> tuple[float, float, float]:
        m = self.mold
        rim = m.ledge_mm + m.clearance_mm + m.wall_mm
        z = m.pour_allowance_mm + m.plate_mm + self.top_height_mm + m.wall_mm
        return self.length_mm + 2 * rim, self.width_mm + 2 * rim, z

    @property
    def interior_mold_size_mm(self) -> tuple[float, float, float]:
        m = self.mold
        return (self.length_mm + 2 * m.ledge_mm, self.width_mm + 2 * m.ledge_mm,
                m.plate_mm + self.chambers.height_mm)

    @property
    def bottom_mold_size_mm(self) -> tuple[float, float, float]:
        m = self.mold
        return (self.length_mm + 2 * m.wall_mm, self.width_mm + 2 * m.wall_mm,
                m.wall_mm + self.bottom_layer.thickness_mm + m.pour_allowance_mm)
