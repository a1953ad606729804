"""Photographs or a video of a bending actuator to a recording: ``pnmold track`` (docs/track.md).

:func:`track` reads the frames (:mod:`.media`), learns the body from the first frame and two clicks
(:mod:`.appearance`), traces it in every frame (:mod:`.centreline`), measures the bend angle and the
tip in pnmold's frame (:mod:`.measure`) at a scale given, found on a grid or from the free length
(:mod:`.scale`), with each frame's pressure (:mod:`.pressures`); :func:`write_outputs` writes the
recording, the JSON summary and the overlay folder (:mod:`.output`, :mod:`.overlay`).

>>> from pnmold.track import TrackOptions, track, write_outputs          # doctest: +SKIP
>>> options = TrackOptions(base_px=(266, 335), tip_px=(266, 232), pressures_kpa=(0, 32.45),
...                        free_length_mm=43.0)                            # doctest: +SKIP
>>> tracking = track(["rest.png", "final.png"], options)                   # doctest: +SKIP
>>> tracking.frames[-1].bend_angle_deg                                     # doctest: +SKIP
"""

from pnmold.track.media import Footage, Frame, read_frames
from pnmold.track.output import recording_text, write_outputs
from pnmold.track.pressures import PressureLog, parse_pressures, read_pressure_log
from pnmold.track.scale import Grid, Scale, find_grid
from pnmold.track.tracker import TrackedFrame, Tracking, TrackOptions, track, track_frames

__all__ = ["Footage", "Frame", "Grid", "PressureLog", "Scale", "TrackOptions", "TrackedFrame", "Tracking",
           "find_grid", "parse_pressures", "read_frames", "read_pressure_log", "recording_text", "track",
           "track_frames", "write_outputs"]
