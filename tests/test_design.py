"""Designs: templates load, overrides apply, bad values are refused naming the field."""

from __future__ import annotations

import dataclasses

import pytest

from pnmold.design import SECTIONS, digest, load_design, to_toml, validate
from pnmold.errors import DesignError
from tests.conftest import TEMPLATES


@pytest.mark.parametrize("template", TEMPLATES)
def test_every_template_loads_valid_and_round_trips(template, tmp_path):
    design = load_design(template)
    assert validate(design) is design
    resolved = tmp_path / "design.toml"
    resolved.write_text(to_toml(design))
    again = load_design(resolved)
    assert again == design
    assert digest(again) == digest(design)


def test_fpn_is_the_supplements_numbers():
    d = load_design("fpn")
    assert d.kind == "fpn"
    assert d.chambers.height_mm == 10.5 and d.channel.height_mm == 1.0
    assert d.chambers.inside_wall_mm == 1.0 and d.inlet.diameter_mm == 2.0
    assert (d.material.c10_mpa, d.material.c20_mpa, d.material.c30_mpa) == (0.11, 0.02, 0.0)
    assert d.paper.modulus_mpa == 6500.0 and d.paper.poisson == 0.2
    assert (d.printer.build_x_mm, d.printer.build_y_mm, d.printer.build_z_mm) == (203, 203, 305)


def test_fig_s2_family_members_keep_their_constants():
    assert load_design("fig-s2a-h5").chambers.count == 15
    b = load_design("fig-s2b-n7")
    assert b.chambers.height_mm == 7.0 and b.chambers.inside_wall_mm == 1.0
    c = load_design("fig-s2c-w2")
    assert c.chambers.height_mm == 10.5 and c.chambers.count == 5


def test_overrides_make_new_values_and_derived_sizes_follow():
    base = load_design("fpn")
    more = load_design("fpn", ["chambers.count=12", "material.name=Ecoflex 00-30"])
    assert more.chambers.count == 12 and more.material.name == "Ecoflex 00-30"
    assert more.length_mm == pytest.approx(base.length_mm + base.pitch_mm)
    taller = base.replace("chambers", height_mm=12.0)
    assert taller.height_mm == pytest.approx(base.height_mm + 1.5)
    assert base.chambers.height_mm == 10.5  # unchanged: frozen values
    with pytest.raises(dataclasses.FrozenInstanceError):
        base.chambers.height_mm = 3.0  # type: ignore[misc]


def test_spn_shares_walls_and_fpn_has_gaps():
    f, s = load_design("fpn"), load_design("spn")
    assert f.pitch_mm == f.chambers.length_mm + 2 * f.chambers.inside_wall_mm + f.chambers.gap_mm
    assert s.pitch_mm == s.chambers.length_mm + s.chambers.inside_wall_mm
    assert s.gap_mm == 0.0


def test_unknown_key_lists_the_valid_ones(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[chambers]\ncolour = 3\n")
    with pytest.raises(DesignError) as info:
        load_design(path)
    assert info.value.field == "chambers.colour"
    for f in dataclasses.fields(SECTIONS["chambers"]):
        assert f.name in str(info.value)


def test_unknown_section_is_refused(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[wings]\nspan_mm = 3\n")
    with pytest.raises(DesignError, match="valid sections"):
        load_design(path)


def test_bad_toml_names_the_file(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("[chambers\ncount = 3\n")
    with pytest.raises(DesignError, match="broken.toml"):
        load_design(path)


def test_unknown_template_lists_the_templates():
    with pytest.raises(DesignError, match="fpn"):
        load_design("no-such-template")


# (override, field named in the error): at least ten distinct ways to be wrong
INVALID = [
    ("chambers.count=2.5", "chambers.count"),                  # integer count
    ("chambers.count=1", "chambers.count"),                    # one chamber has nothing to join
    ("chambers.height_mm=-3", "chambers.height_mm"),           # positive size
    ("chambers.length_mm=0", "chambers.length_mm"),            # positive size
    ("channel.height_mm=12", "channel.height_mm"),             # channel lower than chambers
    ("chambers.gap_mm=0.5", "chambers.gap_mm"),                # exterior plates printable
    ("mold.wall_mm=0.4", "mold.wall_mm"),                      # mold walls printable
    ("chambers.inside_wall_mm=0.5", "chambers.inside_wall_mm"),  # castable elastomer wall
    ("chambers.tip_wall_mm=0.5", "chambers.tip_wall_mm"),      # castable elastomer wall
    ("chambers.tip_wall_mm=-1", "chambers.tip_wall_mm"),       # 0 or a wall
    ("clamp.length_mm=-1", "clamp.length_mm"),                 # 0 or a length
    ("paper.depth_mm=0.5", "paper.depth_mm"),                  # castable rubber below the sheet
    ("paper.depth_mm=1", "bottom_layer.thickness_mm"),         # and above its stops
    ("clamp.length_mm=105", "clamp.length_mm"),                # one chamber at least left free
    ("top_layer.floor_mm=1.2", "top_layer.floor_mm"),          # elastomer over the channel
    ("chambers.count=40", "printer.build_x_mm"),               # build volume
    ("design.kind=xpn", "design.kind"),                        # kinds
    ("material.c10_mpa=0", "material.c10_mpa"),                # material positive
    ("paper.inset_mm=0.5", "paper.inset_mm"),                  # room for the paper stops
    ("inlet.axis_offset_mm=3", "inlet.axis_offset_mm"),        # bore must reach the channel
    ("chambers.height_mm=abc", "chambers.height_mm"),          # a number
    ("paper.poisson=0.6", "paper.poisson"),                    # physical range
]


@pytest.mark.parametrize(("override", "field"), INVALID, ids=[f for _, f in INVALID])
def test_invalid_designs_are_refused_naming_the_field(override, field):
    with pytest.raises(DesignError) as info:
        load_design("fpn", [override])
    assert info.value.field == field
    assert field in str(info.value)


def test_naming_a_library_rubber_loads_its_constants_and_says_so():
    eco = load_design("fpn", ["material.name=ecoflex-00-30"])
    assert eco.material.name == "Ecoflex 00-30"
    assert (eco.material.c10_mpa, eco.material.density_g_per_ml, eco.material.mix_ratio_a_to_b) == (
        0.008167, 1.07, 1.0)
    text = to_toml(eco)
    assert 'name = "Ecoflex 00-30"  # set by the user (--set)' in text
    assert "c10_mpa = 0.008167  # Ecoflex 00-30, pnmold library" in text
    assert "count = 11  # template fpn" in text  # the template set it, not the field's default


@pytest.mark.parametrize(("overrides", "field", "words"), [
    (["material.name=Ecoflex 00-30", "material.c10_mpa=0.11"], "material.c10_mpa", "name of its own"),
    (["material.c10_mpa=0.2"], "material.c10_mpa", "Elastosil M4601's is 0.11"),
    (["material.name=Labsil 7"], "material.c10_mpa", "not in the material library"),
    (["layer_material.c10_mpa=0.2"], "layer_material.c10_mpa", "layer_material.name is empty"),
    (["paper.present=false"], "paper.present", "stiffer rubber"),
], ids=["library-mismatch", "default-mismatch", "unknown-rubber", "layer-without-name", "no-paper-no-layer"])
def test_a_rubber_that_is_not_what_its_name_says_is_refused(overrides, field, words):
    with pytest.raises(DesignError, match=words) as info:
        load_design("fpn", overrides)
    assert info.value.field == field


def test_a_rubber_of_ones_own_needs_every_constant_and_keeps_them(tmp_path):
    own = ["material.name=Labsil 7", "material.c10_mpa=0.05", "material.c20_mpa=0.001", "material.c30_mpa=0",
           "material.density_g_per_ml=1.1", "material.mix_ratio_a_to_b=10"]
    d = load_design("fpn", own)
    assert (d.material.name, d.material.c10_mpa, d.material.mix_ratio_a_to_b) == ("Labsil 7", 0.05, 10.0)
    path = tmp_path / "design.toml"
    path.write_text(to_toml(d))
    assert load_design(path) == d  # a resolved design.toml reads back as it was


@pytest.mark.parametrize("field, value, words", [
    ("material.c10_mpa", "96", "stiffer than any castable"),
    ("material.c10_mpa", "0.0001", "softer than any castable"),
    ("material.density_g_per_ml", "11", "outside castable"),
    ("layer_material.c10_mpa", "1000", "stiffer than any castable"),
])
def test_a_rubber_outside_castable_elastomers_is_refused_saying_which_side(field, value, words):
    prefix = field.split(".")[0]
    own = {f"{prefix}.name": "Labsil 7", f"{prefix}.c10_mpa": "0.05", f"{prefix}.c20_mpa": "0.001",
           f"{prefix}.c30_mpa": "0", f"{prefix}.density_g_per_ml": "1.1", f"{prefix}.mix_ratio_a_to_b": "10",
           field: value}
    with pytest.raises(DesignError, match=words) as info:
        load_design("fpn", [f"{k}={v}" for k, v in own.items()])
    assert info.value.field == field
    own[field] = "0.05" if field.endswith("c10_mpa") else "1.1"
    load_design("fpn", [f"{k}={v}" for k, v in own.items()])  # the same rubber within the range is accepted


def test_overrides_do_not_depend_on_their_order():
    """A rubber's constants set before its name belong to it as much as those set after (they once
    reloaded the library's silently); a key set twice to different values is refused as ambiguous."""
    import itertools

    own = ["material.c10_mpa=0.05", "material.name=Labsil 7", "material.c20_mpa=0.001", "material.c30_mpa=0",
           "material.density_g_per_ml=1.1", "material.mix_ratio_a_to_b=10"]
    designs = {digest(load_design("fpn", [*order, *own[3:]])) for order in itertools.permutations(own[:3])}
    assert len(designs) == 1 and load_design("fpn", own).material.c10_mpa == 0.05
    for order in (["material.c10_mpa=0.2", "material.name=Ecoflex 00-30"],
                  ["material.name=Ecoflex 00-30", "material.c10_mpa=0.2"]):
        with pytest.raises(DesignError, match="name of its own") as info:
            load_design("fpn", order)
        assert info.value.field == "material.c10_mpa"
    with pytest.raises(DesignError, match="set twice") as info:
        load_design("fpn", ["chambers.count=8", "chambers.count=9"])
    assert info.value.field == "chambers.count"


def test_a_rubber_strain_limiting_layer_without_paper():
    d = load_design("fpn", ["paper.present=false", "layer_material.name=Dragon Skin 30"])
    assert not d.paper.present and "paper" not in d.part_names and len(d.part_names) == 6
    assert d.bottom_material.name == "Dragon Skin 30" and d.bottom_material.c10_mpa == 0.09631
    assert load_design("fpn").bottom_material == load_design("fpn").material  # same rubber by default
    slab = d.length_mm * d.width_mm * d.bottom_layer.thickness_mm
    assert d.elastomer_mass_g == pytest.approx(((d.elastomer_volume_mm3 - slab) * 1.13 + slab * 1.08) / 1000)
    assert digest(d) != digest(load_design("fpn"))


def test_the_clamp_length_moves_the_clamp_and_only_then_the_digest():
    base = load_design("fpn")
    assert base.clamp_end_mm == base.proximal_end_mm  # the supplement's: the proximal chamber
    assert digest(load_design("fpn", ["clamp.length_mm=0"])) == digest(base)
    held = load_design("fpn", ["clamp.length_mm=20"])
    assert held.clamp_end_mm == 20.0 and held.free_length_mm == pytest.approx(base.length_mm - 20.0)
    assert digest(held) != digest(base)
    assert "length_mm = 20.0  # set by the user (--set)" in to_toml(held)
