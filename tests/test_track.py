"""``pnmold track``: drawn bending bodies of known shape (a constant-curvature band with a shadow, a
marker, the clamp), a grid, bad input, the real photographs, and the recording read back."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pnmold.cli import main

cv2 = pytest.importorskip("cv2")

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
SIZE = (420, 290)
BASE = (70, 60)  # the clamp's end, bottom face, px
LENGTH_PX, THICK_PX = 250.0, 34.0
MM_PER_PX = 0.25


def band(theta_rad: float, n: int = 240) -> tuple[np.ndarray, np.ndarray]:
    """Bottom (curling) and top edges of a band of LENGTH_PX whose bottom edge keeps its length and
    turns through ``theta_rad`` at constant curvature, in (x along, z up) px from the base's bottom."""
    s = np.linspace(0, LENGTH_PX, n)
    if abs(theta_rad) < 1e-9:
        return np.c_[s, 0 * s], np.c_[s, 0 * s + THICK_PX]
    r = LENGTH_PX / theta_rad
    phi = s / r
    bottom = np.c_[r * np.sin(phi), -r * (1 - np.cos(phi))]
    top = np.c_[0 * s, -r + 0 * s] + (r + THICK_PX) * np.c_[np.sin(phi), np.cos(phi)]
    return bottom, top


def to_px(p: np.ndarray) -> np.ndarray:
    """(x along, z up) px to the picture: the body's top edge at rest along y = BASE[1], its bottom below."""
    return np.c_[BASE[0] + p[:, 0], BASE[1] + THICK_PX - p[:, 1]]


def draw(theta_deg: float, seed: int = 0, grid_px: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A frame (BGR) of the band bent by ``theta_deg`` (curling down in the picture) on a grey board, with
    a soft shadow, a white marker, the black clamp and noise; and the tip (bottom corner) in px."""
    w, h = SIZE
    img = np.full((h, w, 3), (190, 196, 200), np.float32)
    if grid_px:
        for k in np.arange(0, w, grid_px):
            img[:, int(round(k))] = (150, 160, 170)
        for k in np.arange(0, h, grid_px):
            img[int(round(k)), :] = (150, 160, 170)
    bottom, top = band(math.radians(theta_deg))
    poly = to_px(np.vstack([bottom, top[::-1]]))
    shade = np.zeros((h, w), np.uint8)
    cv2.fillPoly(shade, [np.round((poly + [8, 9]) * 8).astype(np.int32)], 1, cv2.LINE_AA, 3)
    img *= (1 - 0.35 * cv2.GaussianBlur(shade.astype(np.float32), (0, 0), 3))[..., None]
    cv2.rectangle(img, (BASE[0] - 45, BASE[1] - 20), (BASE[0], BASE[1] + int(THICK_PX) + 20), (25, 25, 25), -1)
    cv2.fillPoly(img, [np.round(poly * 8).astype(np.int32)], (60, 70, 175), cv2.LINE_AA, 3)
    mid = to_px(((bottom + top) / 2)[len(bottom) // 2][None])[0]
    cv2.circle(img, (int(mid[0]), int(mid[1])), 5, (250, 250, 250), -1)
    img = cv2.GaussianBlur(img, (0, 0), 0.8) + np.random.default_rng(seed).normal(0, 3, img.shape)
    return np.clip(img, 0, 255).astype(np.uint8), to_px(bottom[-1:])[0]


ANGLES = (0.0, 45.0, 110.0, 200.0)


@pytest.fixture(scope="module")
def tracked(tmp_path_factory):
    """Four frames of known bend and one whose body leaves the picture, tracked through the CLI."""
    folder = tmp_path_factory.mktemp("track")
    paths, tips = [], []
    for i, angle in enumerate((*ANGLES, 150.0)):
        image, tip = draw(angle, seed=i)
        cv2.imwrite(str(folder / f"f{i}.png"), image)
        paths.append(str(folder / f"f{i}.png"))
        tips.append(tip)
    base = f"{BASE[0]},{BASE[1] + THICK_PX / 2:.0f}"
    tip = f"{BASE[0] + LENGTH_PX:.0f},{BASE[1] + THICK_PX / 2:.0f}"
    rec, js, overlay = folder / "rec.csv", folder / "track.json", folder / "overlay"
    code = main(["track", *paths, "--base", base, "--tip", tip, "--pressures-kpa", "0,5,10,20,15",
                 "--scale-mm-per-px", str(MM_PER_PX), "--recording", str(rec), "--json", str(js),
                 "--overlay", str(overlay), "-q"])
    import json

    return code, rec, json.loads(js.read_text()) if js.exists() else None, overlay, tips


def test_a_drawn_band_is_read_within_2_degrees_and_2_percent(tracked):
    code, _, doc, _, tips = tracked
    assert code == 0
    frames = doc["frames"]
    assert [f["accepted"] for f in frames[:4]] == [True] * 4
    for f, angle, tip in zip(frames, ANGLES, tips, strict=False):
        assert f["bend_angle_deg"] == pytest.approx(angle, abs=2.0)
        x_mm = (tip[0] - BASE[0]) * MM_PER_PX
        z_mm = -(tip[1] - (BASE[1] + THICK_PX)) * MM_PER_PX
        miss = math.hypot(f["tip_x_mm"] - x_mm, f["tip_z_mm"] - z_mm)
        assert miss <= 0.02 * LENGTH_PX * MM_PER_PX, (f, x_mm, z_mm)
    assert doc["bending_length_mm"] == pytest.approx(LENGTH_PX * MM_PER_PX, rel=0.02)


def test_a_body_out_of_the_picture_is_skipped_with_the_reason(tracked):
    _, rec, doc, _, _ = tracked
    last = doc["frames"][-1]
    assert not last["accepted"] and "out of the picture" in last["reason"]
    assert "## skipped frame 4" in rec.read_text()


def test_the_recording_reads_back_as_pnmold_reads_recordings(tracked):
    from pnmold.recording import read_recording

    _, rec, _, _, _ = tracked
    r = read_recording(rec)
    assert r.kind == "bending" and len(r) == 4
    assert list(r["pressure_kpa"]) == [0, 5, 10, 20]
    assert r.measurement.tip_origin == "clamp"
    assert r.measurement.bending_length_mm == pytest.approx(LENGTH_PX * MM_PER_PX, rel=0.02)
    assert r.metadata["scale_source"] == "mm-per-px"


def test_the_overlay_holds_every_frame_and_a_contact_sheet_and_is_refused_when_foreign(tracked, tmp_path):
    _, rec, _, overlay, _ = tracked
    names = sorted(p.name for p in overlay.glob("*.png"))
    assert names == ["contact_sheet.png", *(f"frame_{i:04d}.png" for i in range(5))]
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("a person's file")
    image, _ = draw(0.0)
    cv2.imwrite(str(tmp_path / "a.png"), image)
    code = main(["track", str(tmp_path / "a.png"), str(tmp_path / "a.png"), "--base", "70,77", "--tip", "320,77",
                 "--pressures-kpa", "0,1", "--scale-mm-per-px", "0.25", "--recording", str(tmp_path / "r.csv"),
                 "--overlay", str(foreign), "-q"])
    assert code == 2 and (foreign / "notes.txt").is_file() and not (tmp_path / "r.csv").exists()


def test_the_build_report_shows_an_overlay_written_into_the_build_folder(tracked, built, tmp_path):
    """`pnmold track ... --overlay BUILD/tracking`, then `pnmold report BUILD`: the page has a camera
    tracking section with the contact sheet and what the overlay's summary says."""
    import shutil

    _, _, doc, overlay, _ = tracked
    folder = tmp_path / "fpn"
    shutil.copytree(built("fpn").out_dir, folder)
    assert "Camera tracking" not in (folder / "report.html").read_text()  # none without an overlay
    shutil.copytree(overlay, folder / "tracking")
    assert main(["report", str(folder), "-q"]) == 0
    page = (folder / "report.html").read_text()
    assert "Camera tracking" in page and "<code>tracking/</code>" in page
    assert f"{doc['frames_accepted']} of {doc['frames_total']} frames accepted" in page
    assert doc["frames_accepted"] == 4 and doc["frames_total"] == 5


def test_a_grid_behind_the_body_gives_the_scale():
    from pnmold.track import find_grid

    image, _ = draw(45.0, grid_px=9.6)
    exclude = np.zeros(image.shape[:2], bool)
    exclude[BASE[1] - 30:, :] = True  # the body and the clamp, roughly
    grid = find_grid(image, exclude)
    assert grid.period_px == pytest.approx(9.6, rel=0.02)


@pytest.mark.parametrize(("args", "field"), [
    (["--base", "900,10"], "--base"),
    (["--pressures-kpa", "0,1,2"], "--pressures-kpa"),
    (["--unreadable"], "bad.png"),
], ids=["base-outside", "pressure-count", "unreadable-file"])
def test_bad_input_exits_2_naming_the_field(args, field, tmp_path, capsys):
    image, _ = draw(0.0)
    good = tmp_path / "a.png"
    cv2.imwrite(str(good), image)
    frames = [str(good), str(good)]
    opts = {"--base": "70,77", "--pressures-kpa": "0,1"}
    if args == ["--unreadable"]:
        (tmp_path / "bad.png").write_text("not an image")
        frames[1] = str(tmp_path / "bad.png")
    else:
        opts[args[0]] = args[1]
    argv = ["track", *frames, "--tip", "320,77", "--scale-mm-per-px", "0.25", "--recording",
            str(tmp_path / "r.csv"), "-q"]
    for k, v in opts.items():
        argv += [k, v]
    assert main(argv) == 2
    assert field in capsys.readouterr().err
    assert not (tmp_path / "r.csv").exists()


@pytest.mark.skipif(not (DATA / "marchese2015_ribbed_photo_rest.png").is_file(),
                    reason="../shared/data (the real photographs) is not beside this checkout")
def test_the_real_photographs_give_the_recorded_final_angle_within_8_degrees(tmp_path):
    import json

    rec = tmp_path / "real.csv"
    code = main(["track", str(DATA / "marchese2015_ribbed_photo_rest.png"),
                 str(DATA / "marchese2015_ribbed_photo_final.png"), "--base", "266,335", "--tip", "266,232",
                 "--pressures-kpa", "0,32.45", "--free-length-mm", "43", "--recording", str(rec), "--json",
                 str(tmp_path / "t.json"), "-q"])
    assert code == 0
    final = json.loads((tmp_path / "t.json").read_text())["frames"][-1]
    assert final["accepted"]
    assert final["bend_angle_deg"] == pytest.approx(72.19, abs=8.0)


def test_a_video_with_a_pressure_log_gives_each_frame_its_time_and_pressure(tmp_path):
    import imageio.v2 as iio

    from pnmold.recording import read_recording

    clip = tmp_path / "clip.mp4"
    with iio.get_writer(clip, format="FFMPEG", fps=2, codec="libx264", macro_block_size=2, pixelformat="yuv444p",
                        output_params=["-crf", "0"]) as w:  # lossless: what is tested is the timing
        for i, angle in enumerate(ANGLES[:3]):
            w.append_data(draw(angle, seed=i)[0][..., ::-1])
    log = tmp_path / "log.csv"
    log.write_text("# a logger's file\ntime_s;pressure_psi\n0;0\n0,5;1\n1;2\n1,5;3\n")
    rec = tmp_path / "rec.csv"
    code = main(["track", str(clip), "--base", f"{BASE[0]},{BASE[1] + THICK_PX / 2:.0f}", "--tip",
                 f"{BASE[0] + LENGTH_PX:.0f},{BASE[1] + THICK_PX / 2:.0f}", "--pressure-log", str(log),
                 "--offset-s", "0.25", "--scale-mm-per-px", str(MM_PER_PX), "--recording", str(rec), "-q"])
    assert code == 0
    r = read_recording(rec)
    assert len(r) >= 2 and r["time_s"][0] == 0.0 and r["bend_angle_deg"][0] == pytest.approx(0.0, abs=2.0)
    frames = np.rint(r["time_s"] * 2).astype(int)  # 2 frames a second
    assert list(r["time_s"]) == pytest.approx(list(frames / 2.0))
    assert list(r["pressure_kpa"]) == pytest.approx(list((frames + 0.5) * 6.894757), rel=1e-4)  # psi at t + 0.25 s
    assert list(r["bend_angle_deg"]) == pytest.approx([ANGLES[i] for i in frames], abs=2.0)
