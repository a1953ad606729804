"""Writing a diagnosis: the JSON (schema pnmold.diagnosis/1) and the report folder."""

from __future__ import annotations

from pathlib import Path

from pnmold.fsutil import staged_dir, write_json, write_text

from .core import Diagnosis


def write_json_doc(diag: Diagnosis, path: str | Path) -> Path:
    return write_json(path, diag.doc)


def write_report(diag: Diagnosis, folder: str | Path) -> Path:
    """``folder``: diagnosis.json, fits.png (data, baseline, improved, residuals with the
    located window) and report.html; built in a temporary folder, then renamed."""
    from .plots import fit_figure

    folder = Path(folder)
    with staged_dir(folder, "diagnosis report") as tmp:
        write_json(tmp / "diagnosis.json", diag.doc)
        fit_figure(diag, tmp / "fits.png")
        write_text(tmp / "report.html", _page(diag, tmp / "fits.png"))
    return folder


def _page(diag: Diagnosis, figure: Path) -> str:
    """A self-contained page in the build report's style, the figure inlined."""
    from pnmold.report.html import esc, image, page, table

    doc, fit = diag.doc, diag.doc["fit"]
    mismatch = "".join(f"<li>{esc(m['description'])}</li>" for m in doc["mismatch"]) or "<li>none</li>"
    fits = table(["", "all rows", "held out"], [
        ["baseline (modulus recalibrated)", f"{fit['rmse_before']:.4g}", f"{fit['heldout_rmse_before']:.4g}"],
        ["final model", f"{fit['rmse_after']:.4g}", f"{fit['heldout_rmse_after']:.4g}"]])
    candidates = table(
        ["effect", "held-out chi2 per point", "chi2 gain", "excess removed", "bootstrap wins", "plausible", "notes"],
        [[esc(c["effect"]), f"{c['heldout_chi2_per_point']:.3g}", f"{c['heldout_chi2_gain']:.0f}",
          f"{100 * c['excess_removed']:.0f}%", f"{100 * c['bootstrap_wins']:.0f}%",
          "yes" if c["plausible"] else "no", esc("; ".join(c["notes"]))] for c in doc["candidates"]])
    sections = [
        ("summary", "What is missing", f"<p>{esc(doc['summary'])}</p>"),
        ("mismatch", "Where the calibrated model misses", f"<ul>{mismatch}</ul>"),
        ("fit", f"Fit of {fit['observable']}", fits + image(figure.read_bytes(), "data, baseline, improved model "
                                                             "and residuals with the located window")),
        ("candidates", "Candidate effects", candidates),
        ("recordings", "Recordings", "<ul>" + "".join(f"<li>{esc(r['path'])} ({esc(r['kind'])}, {r['rows']} rows)"
                                                      f"</li>" for r in doc["recordings"]) + "</ul>"),
    ]
    return page(f"pnmold diagnosis: {doc['design']['name']}", sections)
