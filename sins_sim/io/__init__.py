"""Files: recordings in the shared format ``sins-sim-recording/1`` (``recording-format.md``)."""

from sins_sim.io.recording import (
    CSV_COLUMNS,
    FORMAT,
    NOMINAL_KEYS,
    Recording,
    RecordingError,
    check_recording,
    read_csv_recording,
    read_recording,
    write_recording,
)

__all__ = ["CSV_COLUMNS", "FORMAT", "NOMINAL_KEYS", "Recording", "RecordingError", "check_recording",
           "read_csv_recording", "read_recording", "write_recording"]
