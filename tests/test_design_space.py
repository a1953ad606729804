"""Property: every design is either refused with a DesignError before any CAD, or builds
parts that pass every check of the gate."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings

from pnmold.errors import DesignError
from pnmold.pipeline import build
from tests.strategies import design_overrides, load_drawn


@pytest.mark.slow
@settings(max_examples=25, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(overrides=design_overrides())
def test_refused_or_passes_every_check(overrides, tmp_path_factory):
    try:
        design = load_drawn(overrides)
    except DesignError:
        return
    result = build(design, tmp_path_factory.mktemp("draw") / design.name, fem=False, use_slicer=False)
    failed = [(c["id"], c["message"]) for c in result.report["checks"] if c["passed"] is False]
    assert failed == [], overrides
