"""``report.html``: the page a person looks at after a build, one self-contained file.

Everything is inlined (pictures as PNG data URIs, the 3D models as GLB data URIs, the
model-viewer web component's JavaScript), so the page works offline and can be mailed.
The page shell (:func:`page`, :func:`section`, :func:`image`, :func:`table`,
:func:`not_computed`, :func:`model_viewer_head`) is meant for other reports too.
"""

from __future__ import annotations

import base64
import html
import logging
from pathlib import Path
from typing import Any

from pnmold.conventions import MOLDS
from pnmold.errors import PnmoldError, UsageError
from pnmold.fsutil import read_json, write_text
from pnmold.report import render

log = logging.getLogger(__name__)

DATA = Path(__file__).resolve().parents[1] / "data"
MODEL_VIEWER_VERSION = "4.4.0"  # pnmold/data/model-viewer.min.js, see model-viewer.NOTICE
VIEWER_PARTS = ("actuator", *MOLDS)

CSS = """body{font-family:system-ui,sans-serif;margin:0;color:#222;background:#fafafa;line-height:1.4}
header{background:#263238;color:#fff;padding:1em 2em}header h1{margin:0 0 .2em}header p{margin:.2em 0}
nav{background:#37474f;padding:.4em 2em;position:sticky;top:0;z-index:2}
nav a{color:#cfd8dc;margin-right:1em;text-decoration:none}nav a:hover{color:#fff}
main{max-width:72em;margin:0 auto;padding:0 2em 3em}section{margin-top:2em}
h2{border-bottom:2px solid #90a4ae;padding-bottom:.2em}
figure{display:inline-block;margin:.5em;vertical-align:top;background:#fff;border:1px solid #ddd;padding:.4em}
figure img{display:block;max-width:100%}figcaption{font-size:.9em;color:#555;max-width:40em}
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(30em,1fr));gap:.6em}.grid figure{margin:0}
table{border-collapse:collapse;font-size:.9em;background:#fff}td,th{border:1px solid #ddd;padding:.25em .5em;
text-align:left;vertical-align:top}th{background:#eceff1}
tr.pass td:first-child{color:#2e7d32;font-weight:bold}tr.fail td{background:#ffebee}
tr.fail td:first-child{color:#c62828;font-weight:bold}tr.skip td:first-child{color:#ef6c00}
.missing{color:#795548;background:#fff8e1;border-left:4px solid #ffb300;padding:.5em 1em}
.verdict-pass{color:#a5d6a7}.verdict-fail{color:#ef9a9a}
model-viewer{width:100%;height:480px;background:#eef2f4;border:1px solid #ccc}
iframe.checklist{width:100%;height:40em;border:1px solid #ccc;background:#fff}"""


# -- the page shell --------------------------------------------------------------------

def esc(value: Any) -> str:
    return html.escape(str(value), quote=True)


def data_uri(data: bytes, mime: str) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


def image(png: bytes, alt: str, caption: str = "") -> str:
    """A figure with the PNG inlined."""
    cap = f"<figcaption>{caption}</figcaption>" if caption else ""
    return f"<figure><img src='{data_uri(png, 'image/png')}' alt='{esc(alt)}'>{cap}</figure>"


def table(header: list[str], rows: list[list[str]], row_classes: list[str] | None = None) -> str:
    """An HTML table; cells are HTML already (escape text with :func:`esc`)."""
    head = "".join(f"<th>{h}</th>" for h in header)
    classes = row_classes or [""] * len(rows)
    body = "".join(f"<tr class='{c}'>" + "".join(f"<td>{cell}</td>" for cell in row) + "</tr>"
                   for row, c in zip(rows, classes, strict=True))
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def not_computed(reason: str) -> str:
    return f"<p class='missing'>Not computed: {esc(reason)}</p>"


def section(title: str, body: str, anchor: str) -> str:
    return f"<section id='{esc(anchor)}'><h2>{esc(title)}</h2>{body}</section>"


def model_viewer_head() -> str:
    """The model-viewer component, inlined; its decoders point nowhere, so it fetches nothing."""
    js = (DATA / "model-viewer.min.js").read_text(encoding="utf-8")
    config = ("self.ModelViewerElement={dracoDecoderLocation:'data:,',ktx2TranscoderLocation:'data:,',"
              "lottieLoaderLocation:'data:,'};")
    return f"<script>{config}</script><script type='module'>{js}</script>"


def page(title: str, sections: list[tuple[str, str, str]], *, subtitle: str = "", head: str = "") -> str:
    """A whole page: header, a navigation bar, and ``sections`` of (anchor, title, body HTML)."""
    nav = "".join(f"<a href='#{esc(a)}'>{esc(t)}</a>" for a, t, _ in sections)
    body = "".join(section(t, b, a) for a, t, b in sections)
    return (f"<!doctype html><html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='viewport' content='width=device-width,initial-scale=1'><title>{esc(title)}</title>"
            f"<style>{CSS}</style>{head}</head><body><header><h1>{esc(title)}</h1>{subtitle}</header>"
            f"<nav>{nav}</nav><main>{body}</main></body></html>\n")


# -- the build report ------------------------------------------------------------------

def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, dict):
        return ", ".join(f"{k}: {_fmt(v)}" for k, v in value.items())
    if isinstance(value, list | tuple):
        return ", ".join(_fmt(v) for v in value)
    return "–" if value is None else str(value)


def _drawn(what: str, draw) -> str:
    """``draw()`` (an inlined figure), or why it could not be drawn."""
    try:
        return draw()
    except (OSError, ValueError, KeyError, RuntimeError) as err:
        log.warning("report.html: %s not drawn: %s", what, err)
        return not_computed(f"{what} could not be drawn ({type(err).__name__}: {err})")


def _picture(png: bytes | str, what: str, caption: str) -> str:
    """A rendered picture (PNG bytes) as a figure, or the reason it could not be drawn (str)."""
    if isinstance(png, str):
        log.warning("report.html: %s not drawn: %s", what, png)
        return not_computed(f"{what} could not be drawn ({png})")
    return image(png, what, caption)


def _part_names(report: dict[str, Any]) -> list[str]:
    """The build's parts in picture order (a design without paper has no paper sheet)."""
    built = report.get("parts")
    return [n for n in render.PARTS if built is None or n in built]


def _parts(folder: Path, report: dict[str, Any], pictures: dict[str, bytes | str]) -> str:
    figures = []
    for name in _part_names(report):
        if name not in pictures:
            figures.append(not_computed(f"{name}.stl is not in the build folder"))
            continue
        info = report.get("parts", {}).get(name, {})
        (x0, y0, z0), (x1, y1, z1) = info.get("bbox_mm", [[0, 0, 0], [0, 0, 0]])
        turned = " Seen from below (turned over)." if name in render.UPSIDE_DOWN else ""
        caption = (f"<b>{esc(name)}</b>: {info.get('volume_mm3', 0):,.0f} mm³, {x1 - x0:.1f} × {y1 - y0:.1f} × "
                   f"{z1 - z0:.1f} mm.{turned}")
        figures.append(_picture(pictures[name], name, caption))
    return f"<div class='grid'>{''.join(figures)}</div>"


def _viewer(folder: Path, names: list[str]) -> str:
    if not all((folder / f"{n}.stl").is_file() for n in names):
        return not_computed("a part's STL file is missing from the build folder")
    choices = [("molds and actuator, side by side", VIEWER_PARTS)] + [(n, (n,)) for n in names]
    models = [(label, data_uri(render.glb(folder, names), "model/gltf-binary")) for label, names in choices]
    options = "".join(f"<option value='{uri}'>{esc(label)}</option>" for label, uri in models)
    return ("<p>Drag to turn, scroll to zoom. Each part in its use orientation (the exterior mold and the "
            "top layer turned over); colours as in the pictures above. "
            f"<label>Show <select id='model-pick'>{options}</select></label></p>"
            f"<model-viewer id='model-3d' src='{models[0][1]}' alt='molds and actuator' loading='eager' "
            "camera-controls camera-orbit='-30deg 60deg auto' shadow-intensity='0.6' exposure='0.9' "
            "interaction-prompt='none'>"
            "</model-viewer><script>document.getElementById('model-pick').addEventListener('change',"
            "e=>{document.getElementById('model-3d').src=e.target.value;});</script>")


def _checks(report: dict[str, Any]) -> str:
    checks = report.get("checks") or []
    if not checks:
        return not_computed("no design-rule check in report.json")
    order = {False: 0, None: 1, True: 2}
    rows, classes = [], []
    for c in sorted(checks, key=lambda c: order[c["passed"]]):
        status, cls = {True: ("pass", "pass"), False: ("FAIL", "fail"), None: ("skipped", "skip")}[c["passed"]]
        rows.append([status, f"<code>{esc(c['id'])}</code>", esc(_fmt(c.get("value"))),
                     esc(_fmt(c.get("limit"))), esc(c.get("message", ""))])
        classes.append(cls)
    return table(["result", "check", "value", "limit", "finding"], rows, classes)


def _fem_reason(fem: dict[str, Any]) -> str:
    return fem.get("reason") or "the quick FE did not run"


def _bending(folder: Path, fem: dict[str, Any]) -> str:
    steps = fem.get("steps") or []
    png = folder / "bending.png"
    out = (image(png.read_bytes(), "bending", "Deformed shapes, tip trajectory, bend angle and P–V curve "
                 "(bending.png).") if png.is_file() else not_computed(f"no bending.png: {_fem_reason(fem)}"))
    if not steps:
        return out + not_computed(f"P–V curve: {_fem_reason(fem)}")
    v0 = steps[0]["cavity_volume_ml"]
    series = [([s["cavity_volume_ml"] - v0 for s in steps], [s["pressure_kpa"] for s in steps], "quick FE")]
    return out + _drawn("the P–V curve", lambda: image(
        render.curve_png(series, "injected volume (mL)", "pressure (kPa)", "pressure–volume"), "P–V curve",
        f"Cavity pressure against the change of cavity volume over {len(steps)} converged steps (report.json "
        "fem.steps)."))


def _blocked_force(fem: dict[str, Any]) -> str:
    force = fem.get("blocked_force")
    steps = (force or {}).get("steps") or []
    if not steps:
        reason = ((force or {}).get("reason") or "the quick FE of this build did not compute it "
                  "(no fem.blocked_force in report.json)") if fem.get("steps") else _fem_reason(fem)
        return not_computed(reason)
    series = [([s["pressure_kpa"] for s in steps], [s["force_n"] for s in steps], "blocked tip")]
    return _drawn("the blocked-force curve", lambda: image(
        render.curve_png(series, "pressure (kPa)", "force (N)", "blocked tip force"), "blocked force",
        f"Largest force {max(s['force_n'] for s in steps):.3g} N (report.json fem.blocked_force"
        + (f"; {esc(force['method'])}" if force.get("method") else "") + ")."))


def _strain(folder: Path, fem: dict[str, Any], pictures: dict[str, bytes | str]) -> str:
    if "strain" not in pictures:
        return not_computed(f"no fem_field.npz in the build folder ({_fem_reason(fem)})"
                            if not fem.get("steps") else "no fem_field.npz in the build folder")
    caption = "Deformed surface at the last converged step, coloured by the largest principal stretch."
    steps = fem.get("steps") or []
    if steps and "max_stretch_at_mm" in steps[-1]:
        s = steps[-1]
        caption += (f" Largest {s['max_principal_stretch']:.3f} at {s['pressure_kpa']:.1f} kPa, at "
                    f"({_fmt(s['max_stretch_at_mm'])}) mm in the reference frame.")
    touch = fem.get("self_contact")
    if touch:
        peak = (touch.get("max_contact_pressure_kpa") or [0.0])[-1]
        caption += (" Self-contact on: red marks where the walls press on each other "
                    f"(largest {peak:.1f} kPa; first contact at {touch['first_contact_kpa']:.1f} kPa)."
                    if touch.get("first_contact_kpa") is not None else " Self-contact on: the walls never touched.")
    return _picture(pictures["strain"], "the strain picture", caption)


def _slicer(report: dict[str, Any]) -> str:
    slicer = report.get("slicer") or {}
    if not slicer:
        return not_computed("no slicer finding in report.json")
    rows = []
    for mold, est in slicer.items():
        if "print_time_s" in est:
            h, m = divmod(round(est["print_time_s"] / 60), 60)
            rows.append([esc(mold), f"{h} h {m:02d} min", f"{est['filament_g']:.1f} g",
                         f"{est['filament_mm'] / 1000:.2f} m", esc(f"PrusaSlicer {est.get('slicer_version', '')}")])
        else:
            rows.append([esc(mold), "–", "–", "–", esc(f"{est.get('status', '')}: {est.get('message', '')}")])
    return table(["mold", "print time", "ABS", "filament", "note"], rows)


def _pours(report: dict[str, Any]) -> str:
    rows = [[esc(p["mold"]), f"{p['volume_ml']:.2f} mL", f"{p['mass_g']:.1f} g", f"{p['part_a_g']:.1f} g",
             f"{p['part_b_g']:.1f} g"] for p in report.get("pours", [])]
    if not rows:
        return ""
    return "<h3>Elastomer pours</h3>" + table(["pour into", "cast volume", "cast mass", "part A", "part B"], rows)


def _checklist(folder: Path, report: dict[str, Any]) -> str:
    link = ("<p>The printable checklist: <a href='checklist.md'>checklist.md</a> (beside this page); "
            "the same, rendered:</p>")
    try:
        from pnmold.design import load_design
        from pnmold.report.checklist import checklist_sections, render_html

        design = load_design(folder / "design.toml")
        doc = render_html(design, checklist_sections(design, report))
    except (PnmoldError, OSError, KeyError) as err:
        return link + not_computed(f"the checklist could not be rendered ({err})")
    fit = "try{this.style.height=(this.contentDocument.documentElement.scrollHeight+8)+'px'}catch(e){}"
    return link + f"<iframe class='checklist' title='checklist' srcdoc='{esc(doc)}' onload=\"{fit}\"></iframe>"


def _tracking(folder: Path) -> str:
    """The contact sheet of each ``pnmold track`` overlay written into a sub-folder of the build
    folder (``--overlay DIR/tracking``), with what its summary says; '' when there is none."""
    figures = []
    for sub in sorted(p for p in folder.iterdir() if p.is_dir()):
        sheet, summary = sub / "contact_sheet.png", sub / "tracking.json"
        if not (sheet.is_file() and summary.is_file()):
            continue
        try:
            doc = read_json(summary, "tracking summary")
        except PnmoldError as err:
            figures.append(not_computed(f"{sub.name}/: {err}"))
            continue
        scale = doc.get("scale") or {}
        caption = (f"<code>{esc(sub.name)}/</code>: {doc.get('frames_accepted')} of {doc.get('frames_total')} "
                   f"frames accepted ({esc(doc.get('footage', ''))}); scale {esc(_fmt(scale.get('mm_per_px')))} "
                   f"mm/px from {esc(scale.get('source', '?'))}; recording {esc(doc.get('recording', '?'))}")
        figures.append(image(sheet.read_bytes(), f"tracking {sub.name}", caption))
    return "".join(figures)


def picture_jobs(folder: str | Path) -> dict[str, tuple]:
    """The report's pictures of ``folder`` as :mod:`pnmold.report.render` jobs: each part whose STL is
    there, and the strain on the bent actuator once ``fem_field.npz`` is."""
    folder = Path(folder)
    jobs: dict[str, tuple] = {name: ("part", folder / f"{name}.stl", name)
                              for name in render.PARTS if (folder / f"{name}.stl").is_file()}
    if (folder / "fem_field.npz").is_file():
        jobs["strain"] = ("strain", folder / "fem_field.npz")
    return jobs


def report_page(folder: str | Path, report: dict[str, Any] | None = None,
                renderer: render.Renderer | None = None) -> str:
    """The HTML of ``folder``'s report page (``report`` defaults to its report.json).

    ``renderer``: a :class:`~pnmold.report.render.Renderer` already drawing some of the pictures
    (a build starts one early); the rest are sent to it. Default: a new one."""
    folder = Path(folder)
    if report is None:
        path = folder / "report.json"
        if not path.is_file():
            raise UsageError(f"{folder}: no report.json (not a build folder?)")
        report = read_json(path, "build report")
    fem = report.get("fem") or {}
    checks = report.get("checks") or []
    failed = sum(c["passed"] is False for c in checks)
    skipped = sum(c["passed"] is None for c in checks)
    verdict = (f"<span class='verdict-{'fail' if failed else 'pass'}'>checks: {len(checks) - failed - skipped} "
               f"passed, {failed} failed, {skipped} skipped</span>")
    full = fem.get("full_bend_pressure_kpa")
    bend = f"full bend at {full:.1f} kPa (quick FE)" if full is not None else f"full bend: {esc(_fem_reason(fem))}"
    design = report.get("design", {})
    subtitle = (f"<p>{verdict}; {bend}</p><p>design digest {esc(design.get('digest', '?'))}, pnmold "
                f"{esc(report.get('pnmold_version', '?'))}; files beside this page: <a href='report.json'>"
                "report.json</a>, <a href='design.toml'>design.toml</a>, <a href='checklist.md'>checklist.md"
                f"</a>; stage times (s): {esc(_fmt(report.get('timings_s', {})))}</p>")
    jobs = picture_jobs(folder)
    if renderer is None:
        pictures = render.pictures(jobs)
    else:
        renderer.draw({key: job for key, job in jobs.items() if key not in renderer.sent})
        pictures = renderer.results()
    sections = [
        ("parts", "Parts", _parts(folder, report, pictures)),
        ("view3d", "3D view", _drawn("the 3D view", lambda: _viewer(folder, _part_names(report)))),
        ("checks", "Design-rule checks", _checks(report)),
        ("bending", "Bending and pressure–volume", _bending(folder, fem)),
        ("force", "Blocked force", _blocked_force(fem)),
        ("strain", "Largest strain", _strain(folder, fem, pictures)),
        ("slicer", "Print estimates and pours", _slicer(report) + _pours(report)),
        ("checklist", "Checklist", _checklist(folder, report)),
    ]
    tracked = _drawn("the camera tracking", lambda: _tracking(folder))
    if tracked:
        sections.insert(3, ("tracking", "Camera tracking", tracked))
    return page(f"pnmold build: {design.get('name', folder.name)}", sections, subtitle=subtitle,
                head=model_viewer_head())


def write_report(folder: str | Path, report: dict[str, Any] | None = None,
                 renderer: render.Renderer | None = None) -> Path:
    """Write ``folder/report.html`` (atomically) from the build folder's files (``renderer``:
    see :func:`report_page`)."""
    return write_text(Path(folder) / "report.html", report_page(folder, report, renderer))
