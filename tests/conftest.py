"""Shared fixtures: every template built once per session (without the FE); the fPN's
stored free-bending FE steps (tests/data, produced as its ``produced_by`` says) and a
reduced model on them; a session cache of FE characterisations (the templates' own on the
default mesh ship with pnmold, ``pnmold/data/characterisations``, and are read from there)."""

from __future__ import annotations

import json
import os
from pathlib import Path

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


#: the fPN's free-bending FE steps on the coarse mesh (a slow test checks the live FE agrees)
STEPS = json.loads((Path(__file__).parent / "data" / "fpn-free-coarse-steps.json").read_text())["steps"]
@pytest.fixture(scope="session", autouse=True)
def fe_cache(tmp_path_factory):
    """FE characterisations of every test (and of the ``pnmold`` processes tests start) go to a
    session folder, never to ``out/``."""
    folder = tmp_path_factory.mktemp("fe-cache")
    old = os.environ.get("PNMOLD_CACHE")
    os.environ["PNMOLD_CACHE"] = str(folder)
    yield folder
    if old is None:
        os.environ.pop("PNMOLD_CACHE", None)
    else:
        os.environ["PNMOLD_CACHE"] = old


@pytest.fixture(scope="module")
def fpn():
    return load_design("fpn")


@pytest.fixture(scope="module")
def rom(fpn):
    from pnmold.physics import ReducedModel, characterisation_from_steps

    return ReducedModel(fpn, characterisation_from_steps(STEPS, fpn))
