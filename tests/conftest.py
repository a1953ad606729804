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
def actuator_step(tmp_path_factory):
    """template -> its actuator's STEP file (CAD only), exported once per test module that asks."""
    from pnmold.cad import export_parts, make_parts

    got = {}

    def get(name):
        if name not in got:
            folder = tmp_path_factory.mktemp(f"cad-{name}")
            export_parts({"actuator": make_parts(load_design(name))["actuator"]}, folder)
            got[name] = folder / "actuator.step"
        return got[name]

    return get


@pytest.fixture(scope="module")
def live(actuator_step):
    """template -> (design, characterisation, actuator.step), FE on the coarse mesh at
    ``tests.rom_fe.FE_PRESSURE_KPA``, computed once per test module that asks (its files go to the
    session's FE cache)."""
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
            got[name] = (design, c, actuator_step(name))
        return got[name]

    return get


@pytest.fixture(scope="module")
def bundled(actuator_step):
    """template -> (design, characterisation, actuator.step) as ``live``, with the characterisation that
    ships with pnmold (the FE on the same coarse mesh, to 150 kPa, with probe and variants; read, no FE)."""
    from tests.rom_fe import bundled_characterisation

    return lambda name: (load_design(name), bundled_characterisation(name), actuator_step(name))


# -- packing the suite on the two test workers ---------------------------------------------------
# pyproject's addopts run ``--dist loadfile --no-loadscope-reorder``: a file goes whole to one worker
# (its module fixtures run once), and the files are queued in the order the workers collect them,
# which this hook makes heaviest first. xdist's own order (most tests first) left the minutes-long FE
# files of two or three tests (tests/test_rom_spn.py, tests/test_rom_families.py) to the end, on
# one worker while the other idled. Nothing here changes what a test computes or asserts, only
# where and when it runs. (``--dist loadgroup`` cannot split or merge files here: xdist 3.8 marks
# a group in ``item._nodeid``, which pytest 9 no longer reads.)

#: seconds of the heaviest files in a full run (2 workers on a busy machine, --durations=0; tests/test_rom_spn.py,
#: tests/test_rom_families.py and tests/test_design_fe.py scaled by their CPU seconds before and after their
#: reduced models read the bundled characterisations and the fPN's curve was shared): only their order matters,
#: so a stale figure costs some balance, never a result
FILE_SECONDS = {
    "tests/test_design_fe.py": 925, "tests/test_rom.py": 637, "tests/test_export.py": 594,
    "tests/test_rom_families.py": 205, "tests/test_rom_spn.py": 95, "tests/test_sweep.py": 258,
    "tests/test_real_segment.py": 180, "tests/test_pneumatics.py": 132, "tests/test_diagnose.py": 120,
    "tests/test_fem_path.py": 100, "tests/test_contact_fe.py": 60,
    "tests/test_report_html.py": 98, "tests/test_checks.py": 93, "tests/test_cad.py": 77,
    "tests/test_diagnose_step.py": 77, "tests/test_fem.py": 70, "tests/test_install.py": 52,
    "tests/test_cli.py": 50, "tests/test_recording.py": 48, "tests/test_reading.py": 33,
    "tests/test_render.py": 32, "tests/test_mesh.py": 31, "tests/test_design_space.py": 18,
    "tests/test_boundaries.py": 18, "tests/test_checklist.py": 18, "tests/test_progress.py": 15,
    "tests/test_api.py": 14,
}
#: a file not in the table: this much a test
DEFAULT_SECONDS_PER_TEST = 0.5


def pytest_configure(config):
    """On an xdist worker (one of two on the two cores): one thread per numerics library, as the sweep's
    workers run. Two workers with two PARDISO/numba threads each put four threads on two cores:
    measured on tests/test_rom_spn.py + tests/test_rom_families.py on two workers, 293 s wall and
    551 s CPU with two threads each, 208 s and 356 s with one (the same tests passing)."""
    if getattr(config, "workerinput", None) is not None:
        import numba  # loaded first: its run-time setting, NUMBA_NUM_THREADS left as it is (tests/test_sweep.py)
        from threadpoolctl import threadpool_limits

        from pnmold.sweep.run import one_thread

        one_thread()
        threadpool_limits(1)  # numpy's OpenBLAS, loaded before the environment could say so
        assert numba.get_num_threads() == 1


def pytest_collection_modifyitems(config, items):
    if getattr(config, "workerinput", None) is None:
        return  # in one process (-n 0) the collection order stays
    files = {}
    for item in items:
        files.setdefault(item.nodeid.split("::")[0], []).append(item)
    weight = {path: FILE_SECONDS.get(path, DEFAULT_SECONDS_PER_TEST * len(members)) for path, members in files.items()}
    items[:] = [item for path in sorted(files, key=lambda path: -weight[path]) for item in files[path]]
