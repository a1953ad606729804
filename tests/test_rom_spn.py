"""The reduced model against the sPN's FE (slow; see tests/rom_fe.py): with gravity, and its
response to a stretching layer at a value the characterisation's variant runs did not use. The model
reads the sPN's bundled characterisation (the FE on the same coarse mesh; tests/test_rom.py checks the
fPN's bundled one against the live FE) and predicts the live FE runs here."""

from __future__ import annotations

import pytest

from tests.rom_fe import rom_carries_the_fe_response, rom_follows_the_fe_with_gravity


@pytest.mark.slow
def test_rom_follows_the_fe_with_gravity_within_5_percent(bundled):
    failed = rom_follows_the_fe_with_gravity(bundled, "spn")
    assert not failed, failed


@pytest.mark.slow
def test_the_reduced_model_carries_the_fe_response_at_other_values(bundled):
    failed = rom_carries_the_fe_response(bundled, "spn", "layer_compliance", 0.1, (0.5, 0.05))
    assert not failed, failed
