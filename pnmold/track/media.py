"""The frames to track: image files in order, or one video file (every n-th frame), as BGR arrays.

Images are read with OpenCV (PNG, JPEG, TIFF, BMP, ...), videos with imageio and its ffmpeg
(mp4, avi, mov, mkv, ...). A file that cannot be read is a :class:`~pnmold.errors.UsageError`
naming it; so is a video among several files or frames of different sizes.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pnmold.errors import UsageError

log = logging.getLogger(__name__)

#: file endings read as a video (one file holds every frame)
VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".m4v", ".webm", ".mpg", ".mpeg", ".wmv")
#: at most this many frames are tracked from one call (a longer video: raise --every)
MAX_FRAMES = 2000


@dataclass(frozen=True, eq=False)
class Frame:
    """One picture: its place in the sequence, where it came from, its time in the video (s, or None
    for photographs without ``--fps``) and its pixels (BGR, uint8)."""

    index: int
    name: str
    time_s: float | None
    image: np.ndarray

    @property
    def size_px(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return int(self.image.shape[1]), int(self.image.shape[0])


@dataclass(frozen=True)
class Footage:
    """Where the frames came from, for the recording's metadata."""

    source: str
    video: bool
    fps: float | None
    every: int
    size_px: tuple[int, int]
    count: int

    def words(self) -> str:
        w, h = self.size_px
        what = f"video {self.source}" if self.video else f"{self.count} image(s) from {self.source}"
        rate = f", {self.fps:g} fps" if self.fps else ""
        step = f", every {self.every}. frame" if self.every > 1 else ""
        return f"{what}, {w}x{h} px{rate}{step}"


def is_video(path: str | Path) -> bool:
    return Path(path).suffix.lower() in VIDEO_SUFFIXES


def read_frames(paths: list[str], every: int = 1, fps: float | None = None) -> tuple[list[Frame], Footage]:
    """The frames of ``paths`` (images in order, or one video) and a description of them.

    ``every``: keep every n-th frame (video) or image; ``fps``: the frame rate, which gives each
    frame its time (a video's own rate when None)."""
    if every < 1:
        raise UsageError(f"--every: {every} is not a positive whole number")
    if fps is not None and not fps > 0:
        raise UsageError(f"--fps: {fps} is not a positive number")
    videos = [p for p in paths if is_video(p)]
    if videos and len(paths) > 1:
        raise UsageError(f"FRAMES: {videos[0]} is a video; give one video, or image files only")
    for p in paths:
        if not Path(p).is_file():
            raise UsageError(f"FRAMES: {p}: no such file")
    if videos:
        frames, rate = _read_video(videos[0], every, fps)
        source, video = videos[0], True
    else:
        frames = [Frame(i, Path(p).name, None if fps is None else j / fps, _read_image(p))
                  for i, (j, p) in enumerate((j, p) for j, p in enumerate(paths) if j % every == 0)]
        rate, video = fps, False
        source = str(Path(paths[0]).parent) if len(paths) > 1 else paths[0]
    if len(frames) < 1:
        raise UsageError("FRAMES: no frame could be read")
    size = frames[0].size_px
    for f in frames[1:]:
        if f.size_px != size:
            raise UsageError(f"FRAMES: {f.name} is {f.size_px[0]}x{f.size_px[1]} px, the first frame "
                             f"{size[0]}x{size[1]} px: every frame must come from the same camera set-up")
    return frames, Footage(source, video, rate, every, size, len(frames))


def _read_image(path: str) -> np.ndarray:
    import cv2

    data = np.fromfile(path, dtype=np.uint8)
    image = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
    if image is None:
        raise UsageError(f"FRAMES: {path}: not an image OpenCV can read (PNG, JPEG, TIFF, BMP, ...)")
    return image


def _read_video(path: str, every: int, fps: float | None) -> tuple[list[Frame], float | None]:
    import imageio.v2 as iio

    try:
        reader = iio.get_reader(path, format="FFMPEG")
    except Exception as err:  # imageio raises many kinds for a file ffmpeg cannot open
        raise UsageError(f"FRAMES: {path}: not a video ffmpeg can read ({err})") from err
    try:
        rate = fps or reader.get_meta_data().get("fps") or None
        frames = []
        for i, rgb in enumerate(reader):
            if i % every:
                continue
            if len(frames) >= MAX_FRAMES:
                raise UsageError(f"FRAMES: {path} has more than {MAX_FRAMES} frames to track; raise --every")
            image = np.ascontiguousarray(np.asarray(rgb)[..., 2::-1]) if np.ndim(rgb) == 3 else \
                np.repeat(np.asarray(rgb)[..., None], 3, axis=2)
            frames.append(Frame(len(frames), f"{Path(path).name}#{i}", i / rate if rate else None, image))
    except UsageError:
        raise
    except Exception as err:
        raise UsageError(f"FRAMES: {path}: the video cannot be decoded ({err})") from err
    finally:
        reader.close()
    log.debug("read %d frames of %s at %s fps", len(frames), path, rate)
    return frames, rate
