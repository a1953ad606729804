"""Lab recordings: the CSV format (:mod:`.format`), what the metadata says of the rig and the
camera (:mod:`.measurement`, read by the one metadata parser :mod:`.metadata`) and the units a
lab file may carry (:mod:`.units`). The format for users: ``docs/recording-format.md``."""

from pnmold.recording.format import (
    COLUMN_DOCS,
    COLUMNS,
    METADATA_KEYS,
    Recording,
    finite_number,
    format_recording,
    read_recording,
    recording_template,
    write_recording,
    write_template,
)
from pnmold.recording.measurement import Measurement

__all__ = ["COLUMNS", "COLUMN_DOCS", "METADATA_KEYS", "Measurement", "Recording", "finite_number",
           "format_recording", "read_recording", "recording_template", "write_recording", "write_template"]
