"""Files: recordings in the format ``sins-sim-recording/1`` (:mod:`sins_sim.io.recording`),
trajectory files (CSV or Parquet, :mod:`sins_sim.io.trajectory`) and a strapdown unit's own log (counts in its
own axes, :mod:`sins_sim.io.unitlog`)."""

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
from sins_sim.io.trajectory import (
    TRAJECTORY_COLUMNS,
    TrajectoryData,
    TrajectoryFileError,
    read_trajectory,
    write_trajectory,
)
from sins_sim.io.unitlog import LogFileError, LogLayout, UnitLog, read_unit_log

__all__ = ["CSV_COLUMNS", "FORMAT", "NOMINAL_KEYS", "Recording", "RecordingError", "check_recording",
           "read_csv_recording", "read_recording", "write_recording",
           "TRAJECTORY_COLUMNS", "TrajectoryData", "TrajectoryFileError", "read_trajectory", "write_trajectory",
           "LogFileError", "LogLayout", "UnitLog", "read_unit_log"]
