"""The reduced model against the FE of the Fig. S2 templates with gravity (slow; see
tests/rom_fe.py). The model reads each template's bundled characterisation (the FE on the same
coarse mesh, with its probe) and predicts the live FE run here."""

from __future__ import annotations

import pytest

from tests.rom_fe import rom_follows_the_fe_with_gravity

FAMILIES = ("fig-s2a-h5", "fig-s2b-n7", "fig-s2c-w2")


@pytest.mark.slow
@pytest.mark.parametrize("name", FAMILIES)
def test_rom_follows_the_fe_with_gravity_within_5_percent(bundled, name):
    failed = rom_follows_the_fe_with_gravity(bundled, name)
    assert not failed, failed
