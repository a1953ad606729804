"""Shared fixtures: every template built once per session (without the FE)."""

from __future__ import annotations

import pytest

from pnmold.design import list_templates, load_design

TEMPLATES = sorted(list_templates())


@pytest.fixture(scope="session")
def built(tmp_path_factory):
    """template name -> BuildResult, built lazily once per session."""
    from pnmold.pipeline import build

    cache = {}

    def get(name: str):
        if name not in cache:
            out = tmp_path_factory.mktemp(f"build-{name}") / name
            cache[name] = build(load_design(name), out, fem=False)
        return cache[name]

    return get
