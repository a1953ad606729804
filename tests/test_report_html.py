"""report.html: written by every build and by `pnmold report`, self-contained, and opened in
headless Chromium with the network off (no console error, every picture decoded, the 3D
view drew the model, nothing fetched)."""

from __future__ import annotations

import base64
import io
import json
import os
import shutil
import time
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from pnmold.cli import main
from pnmold.design import load_design
from pnmold.fsutil import MARKER
from pnmold.report.html import write_report
from pnmold.report.render import PARTS

#: the parts drawn for the fpn builds below (a design with a passive side draws one more)
DRAWN = [n for n in PARTS if n in load_design("fpn").part_names]

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
MAX_PAGE_BYTES = 20 * 1024 * 1024
LOCAL_LINKS = {"checklist.md", "report.json", "design.toml"}


# -- the build folders -----------------------------------------------------------------

@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    """fpn built without the FE and the slicer: the page as `pnmold build --no-fem` writes it."""
    from pnmold.pipeline import build

    return build(load_design("fpn"), tmp_path_factory.mktemp("report") / "fpn", fem=False, use_slicer=False)


def bent_field(stl: Path, out: Path) -> np.ndarray:
    """fem_field.npz stand-in: the actuator's surface (its y >= 0 half) curled into a full
    circle about the bottom face, which keeps its length; stretch = (R + z) / R."""
    import trimesh

    mesh = trimesh.load(stl, force="mesh")
    mesh = trimesh.Trimesh(*trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=2.0))
    tris = mesh.faces[mesh.triangles_center[:, 1] > 0]
    used, tris = np.unique(tris, return_inverse=True)
    x0 = mesh.vertices[used]
    radius = x0[:, 0].max() / (2 * np.pi)
    theta = x0[:, 0] / radius
    r = radius + x0[:, 2]
    bent = np.column_stack([r * np.sin(theta), x0[:, 1], r * np.cos(theta) - radius])
    stretch = r / radius
    np.savez(out, nodes_mm=x0, displacement_mm=bent - x0, surface_tris=tris.reshape(-1, 3), stretch=stretch)
    return stretch


@pytest.fixture(scope="module")
def full(plain, tmp_path_factory):
    """The plain build plus every optional input: an FE section with steps and a blocked
    force, bending.png, fem_field.npz and slicer estimates; the page rewritten by `pnmold report`."""
    from pnmold.plots import plot_bending

    folder = tmp_path_factory.mktemp("full") / "fpn"
    shutil.copytree(plain.out_dir, folder)
    report = json.loads((folder / "report.json").read_text())
    pressures = np.linspace(0.0, 48.0, 13)
    steps = [{"pressure_kpa": p, "tip_x_mm": 120 - p, "tip_z_mm": -2 * p, "bend_angle_deg": 7.5 * p,
              "cavity_volume_ml": 16.8 + 0.004 * p ** 2, "max_principal_stretch": 1 + 0.022 * p,
              "max_stretch_at_mm": [43.9, 1.2, 2.8], "clamp_reaction_n": [0.0, 0.0, 0.19]} for p in pressures]
    report["fem"] = {"full_bend_pressure_kpa": 48.0, "reason": None, "max_pressure_kpa": 48.0, "steps": steps,
                     "blocked_force": {"steps": [{"pressure_kpa": p, "force_n": 0.015 * p} for p in pressures]}}
    report["slicer"]["mold_bottom"] = {"print_time_s": 4616.0, "filament_mm": 4523.2, "filament_g": 11.31,
                                       "slicer_version": "2.5.0"}
    (folder / "report.json").write_text(json.dumps(report))
    plot_bending("stand-in", steps, [], folder / "bending.png", 48.0)
    bent_field(folder / "actuator.stl", folder / "fem_field.npz")
    assert main(["report", str(folder), "--quiet"]) == 0
    return folder


def page_of(folder: Path) -> str:
    return (folder / "report.html").read_text(encoding="utf-8")


# -- the page as a file ----------------------------------------------------------------

class Fetches(HTMLParser):
    """Every address the page's markup points at (src, href, srcdoc'd markup excluded)."""

    def __init__(self):
        super().__init__()
        self.addresses: list[tuple[str, str, str]] = []
        self.tags: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        for key, value in attrs:
            if key in ("src", "href", "poster", "data", "action", "value") and value:
                self.addresses.append((tag, key, value))


def test_the_inlined_component_cannot_end_its_script_early():
    from pnmold.report.html import DATA

    js = (DATA / "model-viewer.min.js").read_text(encoding="utf-8").lower()
    assert "customelements.define(\"model-viewer\"" in js
    assert "</script" not in js and "<script" not in js  # the HTML parser would end or nest the script
    assert "sourcemappingurl" not in js  # nothing for the devtools to fetch
    assert (DATA / "model-viewer.LICENSE").read_text().lstrip().startswith("Apache License")


def test_build_writes_the_page_and_times_it(plain):
    path = plain.out_dir / "report.html"
    assert path.is_file()
    assert 0 < path.stat().st_size < MAX_PAGE_BYTES
    assert plain.report["timings_s"]["report"] > 0
    assert json.loads((plain.out_dir / "report.json").read_text())["timings_s"]["report"] > 0
    text = page_of(plain.out_dir)
    for name in DRAWN:
        assert f"alt='{name}'" in text, name
    # without the FE: the FE sections say why they are empty
    assert text.count("Not computed: ") >= 4
    assert "skipped (--no-fem)" in text
    assert "model-viewer" in text and "model/gltf-binary;base64," in text


@pytest.mark.parametrize("which", ["plain", "full"])
def test_the_page_points_only_at_itself(which, plain, full):
    folder = plain.out_dir if which == "plain" else full
    parser = Fetches()
    parser.feed(page_of(folder))
    outside = [(t, k, v[:60]) for t, k, v in parser.addresses
               if not (v.startswith(("data:", "#")) or v in LOCAL_LINKS)]
    assert outside == []
    assert ("a", "href", "checklist.md") in parser.addresses
    assert "iframe" in parser.tags and "model-viewer" in parser.tags


def test_every_section_is_filled_when_its_input_is_there(full):
    text = page_of(full)
    assert "Not computed" not in text
    parser = Fetches()
    parser.feed(text)
    images = [v for t, k, v in parser.addresses if t == "img"]
    assert len(images) == len(DRAWN) + 4  # parts, bending.png, P-V, blocked force, strain
    assert all(v.startswith("data:image/png;base64,") for v in images)
    assert "Largest 2.056 at 48.0 kPa" in text
    assert "1 h 17 min" in text and "11.3 g" in text  # the slicer's estimate of mold_bottom
    assert "Fabrication checklist: fpn" in text  # inside the iframe's srcdoc (escaped markup)


def test_the_part_pictures_differ_and_are_not_blank(plain):
    from PIL import Image

    parser = Fetches()
    parser.feed(page_of(plain.out_dir))
    pictures = [base64.b64decode(v.split(",", 1)[1]) for t, k, v in parser.addresses if t == "img"]
    assert len(pictures) == len(DRAWN)
    assert len(set(pictures)) == len(DRAWN)
    for png in pictures:
        img = np.asarray(Image.open(io.BytesIO(png)).convert("L"), float)
        assert img.std() > 10 and (img < 245).mean() > 0.03  # some of the white background is covered


def test_a_crashed_renderer_still_gives_a_page_with_the_reason(plain, tmp_path, monkeypatch):
    import sys

    from pnmold.report.html import report_page

    fake = tmp_path / "python"
    fake.write_text("#!/bin/sh\nkill -SEGV $$\n")
    fake.chmod(0o755)
    monkeypatch.setattr(sys, "executable", str(fake))
    text = report_page(plain.out_dir)
    assert text.count("could not be drawn (the renderer stopped (exit code -11))") == len(DRAWN)
    assert "model/gltf-binary;base64," in text  # the 3D view needs no offscreen OpenGL


def test_report_verb_needs_a_build_folder(tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 2
    assert "report.json" in capsys.readouterr().err
    assert not (tmp_path / "report.html").exists()


def test_write_report_replaces_the_page(plain, tmp_path):
    folder = tmp_path / "fpn"
    shutil.copytree(plain.out_dir, folder)
    (folder / "report.html").write_text("old")
    write_report(folder)
    assert page_of(folder).startswith("<!doctype html>")
    hidden = [p.name for p in folder.iterdir() if p.name.startswith(".")]
    assert hidden == [MARKER]  # the build's marker, no temporary file left


# -- the page in a browser -------------------------------------------------------------

@pytest.fixture(scope="module")
def browser():
    """Headless Chromium (Debian's, with its chromedriver), network off: a dead proxy and no DNS."""
    missing = [str(p) for p in (CHROMIUM, CHROMEDRIVER) if not p.exists()]
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        missing.append("selenium (pip)")
    if missing:
        if os.environ.get("PNMOLD_ALLOW_NO_BROWSER") == "1":
            pytest.skip(f"no browser: {', '.join(missing)}")
        pytest.fail(f"missing {', '.join(missing)}: run scripts/setup.sh (PNMOLD_ALLOW_NO_BROWSER=1 skips)")
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1280,900",
                "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                "--proxy-server=http://127.0.0.1:9", "--proxy-bypass-list=<-loopback>",
                "--host-resolver-rules=MAP * ~NOTFOUND", "--disable-background-networking",
                "--disable-component-update", "--no-first-run"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SE_OFFLINE", "true")  # Selenium Manager must not look for drivers online
        driver = webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=options)
    driver.set_script_timeout(180)
    driver.set_page_load_timeout(180)
    yield driver
    driver.quit()


def png_array(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float)


WAIT_FOR_MODEL = """const mv = arguments[0], done = arguments[arguments.length - 1], t0 = performance.now();
(function poll() {
  if (mv.loaded && mv.modelIsVisible) done({ok: true, ms: performance.now() - t0});
  else if (performance.now() - t0 > 150000) done({ok: false, loaded: mv.loaded, visible: mv.modelIsVisible});
  else setTimeout(poll, 100);
})();"""


@pytest.mark.slow
@pytest.mark.parametrize("which", ["plain", "full"])
def test_the_page_works_offline_in_chromium(which, plain, full, browser):
    folder = plain.out_dir if which == "plain" else full
    for log in ("browser", "performance"):
        browser.get_log(log)  # start from empty logs
    browser.get((folder / "report.html").resolve().as_uri())

    images = browser.execute_script("return [...document.images].map(i => [i.alt, i.complete, i.naturalWidth])")
    assert len(images) == len(DRAWN) + (4 if which == "full" else 0)
    assert [alt for alt, complete, width in images if not (complete and width > 0)] == []
    checklist = browser.execute_script(
        "return document.querySelector('iframe.checklist').contentDocument.body.innerText")
    assert "Fabrication checklist: fpn" in checklist

    page = png_array(browser.get_screenshot_as_png())
    assert page.std() > 20  # not a blank page

    viewer = browser.find_element("css selector", "model-viewer")
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", viewer)
    state = browser.execute_async_script(WAIT_FOR_MODEL, viewer)
    assert state["ok"], state
    time.sleep(0.5)
    shot = png_array(viewer.screenshot_as_png)
    background = np.median(shot.reshape(-1, 3), axis=0)
    drawn = (np.abs(shot - background).max(axis=2) > 40).mean()
    assert drawn > 0.03, f"model-viewer drew {drawn:.1%} of its pixels"
    assert shot.std() > 10

    if which == "full":  # another model from the menu loads too
        state = browser.execute_async_script("""const mv = arguments[0], done = arguments[1];
            const pick = document.getElementById('model-pick');
            mv.addEventListener('load', () => done({loaded: mv.loaded, src: mv.src === pick.value}), {once: true});
            pick.selectedIndex = [...pick.options].findIndex(o => o.text === 'actuator');
            pick.dispatchEvent(new Event('change'));""", viewer)
        assert state == {"loaded": True, "src": True}

    severe = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert severe == []
    requested = [json.loads(e["message"])["message"] for e in browser.get_log("performance")]
    urls = [m["params"]["request"]["url"] for m in requested if m["method"] == "Network.requestWillBeSent"]
    assert urls and [u[:80] for u in urls if not u.startswith(("data:", "file:", "about:", "blob:"))] == []
