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


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    """template -> (design, characterisation, actuator.step), FE on the coarse mesh at
    ``tests.rom_fe.FE_PRESSURE_KPA``, computed once per test module that asks (its files go to the
    session's FE cache)."""
    from pnmold.cad import export_parts, make_parts
    from pnmold.physics import characterise
    from pnmold.physics.characterise import DEFAULT_MAX_PRESSURE_KPA
    from tests.rom_fe import COARSE, FE_PRESSURE_KPA, WITH_VARIANTS

    got = {}

    def get(name):
        if name not in got:
            design = load_design(name)
            assert FE_PRESSURE_KPA[name] != DEFAULT_MAX_PRESSURE_KPA  # another key than the bundled: the FE runs
            c = characterise(design, size=COARSE, max_pressure_kpa=FE_PRESSURE_KPA[name],
                             variants=name in WITH_VARIANTS)
            folder = tmp_path_factory.mktemp(f"cad-{name}")
            export_parts({"actuator": make_parts(design)["actuator"]}, folder)
            got[name] = (design, c, folder / "actuator.step")
        return got[name]

    return get
