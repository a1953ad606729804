"""``pnmold track`` against truth: films rendered from pnmold's own FE, and two real photographs.

The FE solves the default fPN without gravity in the bending plane (``--orientation horizontal
--effects gravity=0``: a body lying on a bench, its weight carried, so that the side view is the
whole story) from 0 to 44 kPa in 4 kPa steps and writes every converged step (VTU) and its own
recording. Each step's deformed body is drawn as a camera beside the bench would see it (the x-z
plane), in three set-ups: a milky-white body on a dark board with a grey grid, a black body on a
pale board with a blue 2.5 mm grid, a pink body on a green cutting mat; each with a soft shadow,
markers on the body, the clamp and the tubing, a lens tilt (3 degrees) and roll, blur and noise.
Three more frames per film must be refused or read right: the camera bumped (15 px), a hand over
the body, the camera covered. The films are tracked through the command line (a PNG sequence with
a grid for the scale, an mp4 video matched to a pressure log by its frame rate with the design's
free length for the scale, a PNG sequence with the free length given), and every accepted frame is
compared with the FE's step: the bend angle's error (deg) and the tip's (% of the 100 mm free
length); a frame accepted with an error past 2 deg or 2 %, or a covered camera accepted, counts as
accepted wrongly.

Then the two photographs of the ribbed segment of Marchese et al. (2015) in ../shared/data (read
from there, never copied): the tracked final angle against the recorded 72.19 deg; and the video's
recording and the FE's own are both diagnosed (``pnmold diagnose fpn``) and their verdicts compared.

    .venv/bin/python benchmarks/track.py [--out out/bench-track]
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PNMOLD = [sys.executable, "-m", "pnmold.cli"]
DATA = ROOT.parent / "shared" / "data"
FREE_LENGTH_MM = 100.0  # the fPN's, from the clamp's end (11 mm) to the tip (111 mm)
CLAMP_END_MM = 11.0
PX_PER_MM = 3.0
SIZE = (640, 480)
ORIGIN_PX = (150.0, 170.0)  # where (x, z) = (0, 0) is drawn before the lens
SCENES = {
    "white-on-dark": {"body": (222, 226, 226), "layer": (200, 205, 205), "board": (58, 48, 40),
                      "grid": (110, 105, 100), "marker": (20, 20, 20), "clamp": (150, 150, 150)},
    "black-on-pale": {"body": (38, 36, 36), "layer": (55, 52, 52), "board": (214, 214, 206),
                      "grid": (200, 150, 120), "marker": (245, 245, 245), "clamp": (28, 28, 28)},
    "pink-on-mat": {"body": (160, 150, 235), "layer": (150, 135, 220), "board": (70, 120, 60),
                    "grid": (120, 170, 110), "marker": (30, 30, 30), "clamp": (60, 60, 60)},
}


def fe_truth(folder: Path) -> tuple[list[dict], list[Path]]:
    """The FE's steps (its recording) and VTU files, solved once into ``folder``."""
    rec, vtu = folder / "fe.csv", folder / "vtu"
    if not rec.is_file():
        subprocess.run([*PNMOLD, "simulate", "fpn", "--model", "fe", "--orientation", "horizontal", "--effects",
                        "gravity=0", "--pressures", "0:44:4", "--vtu", str(vtu), "--recording", str(rec), "-q"],
                       check=True, cwd=ROOT)
    rows = [r for r in csv.DictReader(line for line in rec.read_text().splitlines() if not line.startswith("#"))]
    steps = [{k: float(v) for k, v in r.items() if k in ("pressure_kpa", "tip_x_mm", "tip_z_mm", "bend_angle_deg")}
             for r in rows]
    return steps, sorted(vtu.glob("step_*.vtu"))


def lens(tilt_deg: float = 3.0, roll_deg: float = 2.0) -> np.ndarray:
    """A homography: the camera tilted about the picture's horizontal axis and rolled about its centre."""
    f = 1.6 * SIZE[0]
    k = np.array([[f, 0, SIZE[0] / 2], [0, f, SIZE[1] / 2], [0, 0, 1.0]])
    t, r = math.radians(tilt_deg), math.radians(roll_deg)
    rx = np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])
    rz = np.array([[math.cos(r), -math.sin(r), 0], [math.sin(r), math.cos(r), 0], [0, 0, 1]])
    h = k @ rz @ rx @ np.linalg.inv(k)
    c = h @ np.array([SIZE[0] / 2, SIZE[1] / 2, 1.0])
    shift = np.array([[1, 0, SIZE[0] / 2 - c[0] / c[2]], [0, 1, SIZE[1] / 2 - c[1] / c[2]], [0, 0, 1]])
    return shift @ h  # the picture's centre stays where it was


def to_px(xz: np.ndarray, h: np.ndarray | None = None) -> np.ndarray:
    p = np.column_stack([ORIGIN_PX[0] + PX_PER_MM * xz[:, 0], ORIGIN_PX[1] - PX_PER_MM * xz[:, 1], np.ones(len(xz))])
    if h is not None:
        p = p @ h.T
    return p[:, :2] / p[:, 2:]


class Body:
    """The FE mesh's outer faces, projected on x-z, at each step's displacement."""

    def __init__(self, vtu: list[Path]):
        import meshio

        first = meshio.read(vtu[0])
        self.ref = first.points
        tets = first.cells[0].data[:, :4]
        faces = np.sort(np.concatenate([tets[:, [0, 1, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 3]],
                                        tets[:, [1, 2, 3]]]), axis=1)
        uniq, count = np.unique(faces, axis=0, return_counts=True)
        self.faces = uniq[count == 1]
        self.layer = self.ref[self.faces].mean(axis=1)[:, 2] < 2.0  # the strain-limiting layer
        self.disp = [meshio.read(p).point_data["displacement_mm"] for p in vtu]

    def xz(self, step: int) -> np.ndarray:
        return (self.ref + self.disp[step])[:, [0, 2]]

    def point(self, step: int, ref_xyz: tuple[float, float, float]) -> np.ndarray:
        i = int(np.argmin(np.linalg.norm(self.ref - np.array(ref_xyz), axis=1)))
        return self.xz(step)[i]


def render(body: Body, step: int, scene: dict, h: np.ndarray, seed: int, spoil: str | None = None) -> np.ndarray:
    """One frame (BGR) of ``step`` in ``scene``; ``spoil``: panned / hand / covered."""
    import cv2

    w, hh = SIZE
    s = 4  # supersampled, then shrunk: anti-aliased edges
    big = np.zeros((hh * s, w * s, 3), np.float32)
    big[:] = scene["board"]
    yy, xx = np.mgrid[0:hh * s, 0:w * s] / s
    light = 1.0 + 0.12 * (xx / w - 0.5) - 0.08 * (yy / hh - 0.5)
    big *= light[..., None]
    period = 2.5 * PX_PER_MM
    gx = np.abs(((xx - ORIGIN_PX[0]) / period + 0.5) % 1 - 0.5) * period < 0.5
    gy = np.abs(((yy - ORIGIN_PX[1]) / period + 0.5) % 1 - 0.5) * period < 0.5
    big[gx | gy] = scene["grid"]
    xz = body.xz(step)
    tri = [(to_px(xz[f]) * s).astype(np.int32) for f in body.faces]
    shadow = np.zeros((hh * s, w * s), np.uint8)
    cv2.fillPoly(shadow, [t + np.int32([10 * s, 12 * s]) for t in tri], 1)
    shadow = cv2.GaussianBlur(shadow.astype(np.float32), (0, 0), 4 * s)
    big *= (1 - 0.4 * shadow)[..., None]
    tube = to_px(np.array([[-60.0, 5.0], [-35.0, 2.0], [-16.0, 7.0]])) * s
    cv2.polylines(big, [tube.astype(np.int32)], False, (90, 90, 90), 5 * s)
    for k, t in enumerate(tri):
        cv2.fillPoly(big, [t], scene["layer"] if body.layer[k] else scene["body"])
    for x in (35.0, 60.0, 85.0):
        c = to_px(body.point(step, (x, 10.0, 7.0))[None])[0] * s
        cv2.circle(big, (int(c[0]), int(c[1])), int(1.0 * PX_PER_MM * s), scene["marker"], -1)
    clamp = to_px(np.array([[-16.0, -8.0], [CLAMP_END_MM, -8.0], [CLAMP_END_MM, 22.5], [-16.0, 22.5]])) * s
    cv2.fillPoly(big, [clamp.astype(np.int32)], scene["clamp"])
    if spoil == "hand":
        c = to_px(body.point(step, (60.0, 0.0, 7.0))[None])[0] * s
        cv2.ellipse(big, (int(c[0]), int(c[1])), (30 * s, 55 * s), 30, 0, 360, (120, 150, 190), -1)
    img = cv2.resize(np.clip(big, 0, 255), (w, hh), interpolation=cv2.INTER_AREA)
    if spoil == "panned":  # the camera bumped: everything 15 px to the right
        img = np.roll(img, 15, axis=1)
    if spoil == "covered":
        img[:] = 20
    img = cv2.warpPerspective(img, h, (w, hh), borderMode=cv2.BORDER_REPLICATE)
    img = cv2.GaussianBlur(img, (0, 0), 0.8)
    rng = np.random.default_rng(seed)
    return np.clip(img + rng.normal(0, 3.0, img.shape), 0, 255).astype(np.uint8)


def clicks(body: Body, h: np.ndarray) -> tuple[str, str]:
    base = to_px(np.array([[CLAMP_END_MM + 0.5, 7.25]]), h)[0]
    end = body.xz(0)[np.abs(body.ref[:, 0] - 111.0) < 1e-6].mean(axis=0)
    tip = to_px(end[None], h)[0]
    return f"{base[0]:.0f},{base[1]:.0f}", f"{tip[0]:.0f},{tip[1]:.0f}"


def film(body: Body, steps: list[dict], scene: str, out: Path, h: np.ndarray) -> tuple[list[Path], list[dict]]:
    """The frames of one scene: every FE step, then the camera bumped, a hand over the body, the camera covered."""
    import cv2

    out.mkdir(parents=True, exist_ok=True)
    plan = [(i, None) for i in range(len(steps))] + [(3, "panned"), (4, "hand"), (5, "covered")]
    paths, truth = [], []
    for k, (i, spoil) in enumerate(plan):
        image = render(body, i, SCENES[scene], h, seed=k, spoil=spoil)
        p = out / f"frame_{k:03d}.png"
        cv2.imwrite(str(p), image)
        paths.append(p)
        truth.append(steps[i] | {"spoil": spoil})
    return paths, truth


def run_track(frames: list[Path], base: str, tip: str, extra: list[str], out: Path) -> dict:
    cmd = [*PNMOLD, "track", *map(str, frames), "--base", base, "--tip", tip, "--recording", str(out / "rec.csv"),
           "--json", str(out / "track.json"), "--overlay", str(out / "overlay"), "--orientation", "horizontal",
           "-q", *extra]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, cwd=ROOT)
    doc = json.loads((out / "track.json").read_text())
    doc["seconds"] = time.perf_counter() - t0
    return doc


def score(doc: dict, truth: list[dict]) -> dict:
    angle, tip, wrong, accepted = [], [], 0, 0
    for f, t in zip(doc["frames"], truth, strict=True):
        if not f["accepted"]:
            continue
        accepted += 1
        if t["spoil"] == "covered":
            wrong += 1
            continue
        da = abs(f["bend_angle_deg"] - t["bend_angle_deg"])
        dt = math.hypot(f["tip_x_mm"] - t["tip_x_mm"], f["tip_z_mm"] - t["tip_z_mm"]) / FREE_LENGTH_MM * 100
        angle.append(da)
        tip.append(dt)
        wrong += int(da > 2.0 or dt > 2.0)
    return {"frames": len(truth), "accepted": accepted, "angle_max_deg": max(angle, default=float("nan")),
            "tip_max_pct": max(tip, default=float("nan")), "wrong": wrong}


def write_pressure_log(path: Path, steps: list[dict], fps: float) -> None:
    """A logger at 50 Hz holding each step's pressure over the frame it shows (then the spoiled ones)."""
    n = len(steps) + 3
    t = np.arange(0, n / fps, 0.02)
    p = [steps[min(int(x * fps), len(steps) - 1)]["pressure_kpa"] if int(x * fps) < len(steps) else
         steps[[3, 4, 5][min(int(x * fps) - len(steps), 2)]]["pressure_kpa"] for x in t]
    path.write_text("time_s,pressure_kpa\n" + "".join(f"{a:.3f},{b:.3f}\n" for a, b in zip(t, p, strict=True)))


def video(frames: list[Path], path: Path, fps: float) -> None:
    import cv2
    import imageio.v2 as iio

    with iio.get_writer(path, format="FFMPEG", fps=fps, codec="libx264", quality=9, macro_block_size=16) as w:
        for f in frames:
            w.append_data(cv2.imread(str(f))[..., ::-1])


def verdict(recording: Path, out: Path) -> dict:
    js = out / f"{recording.stem}.diagnosis.json"
    subprocess.run([*PNMOLD, "diagnose", "fpn", str(recording), "--json", str(js), "-q"], check=True, cwd=ROOT)
    doc = json.loads(js.read_text())
    return {"missing": [m["effect"] for m in doc["missing_physics"]], "unexplained": doc["unexplained"]}


def real_photos(out: Path) -> dict | None:
    rest, final = DATA / "marchese2015_ribbed_photo_rest.png", DATA / "marchese2015_ribbed_photo_final.png"
    if not rest.is_file():
        return None
    doc = run_track([rest, final], "266,335", "266,232", ["--pressures-kpa", "0,32.45", "--free-length-mm", "43"],
                    out)
    return doc["frames"][-1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/bench-track")
    args = parser.parse_args()
    out = (ROOT / args.out).resolve()
    steps, vtu = fe_truth(out / "fe")
    body, h = Body(vtu), lens()
    base, tip = clicks(body, h)
    print(f"FE: fPN without gravity in the bending plane, {len(steps)} steps to {steps[-1]['pressure_kpa']:g} kPa "
          f"({steps[-1]['bend_angle_deg']:.0f} deg); clicks base {base}, tip {tip}")
    fps = 5.0
    runs = {}
    for scene, how in zip(SCENES, ("grid", "video", "free-length"), strict=True):
        frames, truth = film(body, steps, scene, out / scene / "frames", h)
        pressures = ",".join(f"{t['pressure_kpa']:g}" for t in truth)
        if how == "grid":
            extra = ["--pressures-kpa", pressures, "--design", "fpn", "--grid-mm", "2.5"]
        elif how == "free-length":
            extra = ["--pressures-kpa", pressures, "--design", "fpn", "--free-length-mm", f"{FREE_LENGTH_MM:g}"]
        else:
            clip = out / scene / "film.mp4"
            video(frames, clip, fps)
            write_pressure_log(out / scene / "pressure_log.csv", steps, fps)
            frames = [clip]
            extra = ["--pressure-log", str(out / scene / "pressure_log.csv"), "--offset-s", f"{0.5 / fps:g}",
                     "--design", "fpn"]
        doc = run_track(frames, base, tip, extra, out / scene)
        runs[scene] = (score(doc, truth), doc)
        s = runs[scene][0]
        print(f"{scene:14s} ({how:11s}): {s['accepted']:2d}/{s['frames']} frames accepted, bend angle error max "
              f"{s['angle_max_deg']:.2f} deg, tip error max {s['tip_max_pct']:.2f} % of the free length, accepted "
              f"wrongly {s['wrong']}; scale {doc['scale']['mm_per_px']:.5f} mm/px ({doc['scale']['source']}, true "
              f"{1 / PX_PER_MM:.5f} before the lens), {doc['seconds']:.1f} s")
    worst = {k: max(r[0][k] for r in runs.values()) for k in ("angle_max_deg", "tip_max_pct", "wrong")}
    print(f"all films: bend angle error max {worst['angle_max_deg']:.2f} deg (target 2), tip error max "
          f"{worst['tip_max_pct']:.2f} % (target 2), accepted wrongly {worst['wrong']} (target 0)")
    final = real_photos(out / "real")
    if final is None:
        print("real photographs: ../shared/data absent, skipped")
    else:
        print(f"real photographs (Marchese 2015, ribbed segment): tracked final bend {final['bend_angle_deg']:.1f} deg "
              f"(from its {final['angle_from']}, confidence {final['confidence']}), recorded 72.19 deg: off by "
              f"{abs(final['bend_angle_deg'] - 72.19):.1f} deg (target 8)")
    tracked = verdict(out / "black-on-pale" / "rec.csv", out)
    own = verdict(out / "fe" / "fe.csv", out)
    print(f"diagnose fpn: the tracked video's recording {tracked}, the FE's own {own}: "
          f"{'same verdict' if tracked == own else 'DIFFERENT verdicts'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
