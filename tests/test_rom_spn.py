"""The reduced model against the sPN's FE (slow; see tests/rom_fe.py): with gravity, and its
response to a stretching layer at a value the characterisation's variant runs did not use."""

from __future__ import annotations

import pytest

from tests.rom_fe import rom_carries_the_fe_response, rom_follows_the_fe_with_gravity


@pytest.mark.slow
def test_rom_follows_the_fe_with_gravity_within_5_percent(live):
    failed = rom_follows_the_fe_with_gravity(live, "spn")
    assert not failed, failed


@pytest.mark.slow
def test_the_reduced_model_carries_the_fe_response_at_other_values(live):
    failed = rom_carries_the_fe_response(live, "spn", "layer_compliance", 0.1, (0.5, 0.05))
    assert not failed, failed
