"""The sweep's folder: results as they finish, atomically, and what a resumed sweep finds there.

Layout of ``--out DIR``::

    DIR/
      .sins-sim-output       marker: a folder sins-sim wrote
      sweep.json             what the folder holds (format, sweep name and file, version, tasks)
      sweep.yaml             a copy of the sweep file as run
      runs/<key>.parquet     one row per finished run, written as it finishes (a part)
      failed/<key>.json      a failed run: unit, scenario, drawn parameters, error and traceback
      runs.parquet           the sweep's table: this sweep's parts in (scenario, unit) order
      summary.json           runs, failed, percentiles of every metric per filter
      *.png                  distributions and sensitivities

Each part is written to a hidden temporary file in ``runs/`` and renamed into place (``os.replace``),
so a part is complete or absent; an interrupted sweep leaves finished parts behind and a resumed one
runs only the keys without a part. ``runs/`` is a cache keyed by run: parts of an earlier definition of
the sweep stay there but are not in ``runs.parquet``. Failed runs are tried again on a resume.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

from sins_sim.jobs.output import MARKER, atomic_write_text
from sins_sim.config.errors import ConfigError

__all__ = ["SweepStore", "FORMAT"]

#: The ``format`` of ``sweep.json``.
FORMAT = "sins-sim-sweep/1"
_TMP = ".tmp-"


class SweepStore:
    """The result folder of one sweep (module docstring)."""

    def __init__(self, root, flag: str = "--out"):
        self.root = Path(os.path.expanduser(str(root)))
        self.flag = flag
        self.runs = self.root / "runs"
        self.failed = self.root / "failed"

    def check(self) -> None:
        """The folder can hold this sweep: absent, empty, or a sweep folder; checked before anything runs."""
        p, flag = self.root, self.flag
        if not str(p).strip():
            raise ConfigError(f"{flag}: must name a directory")
        if p.exists() or p.is_symlink():
            if not p.is_dir():
                raise ConfigError(f"{flag}: {p} exists and is not a directory")
            entries = os.listdir(p)
            if entries and not (p / "sweep.json").is_file():
                what = "a result of another sins-sim command" if MARKER in entries else "files sins-sim did not write"
                raise ConfigError(f"{flag}: {p} holds {what}, not a sweep (no sweep.json): choose another directory")
            if entries:
                try:
                    state = json.loads((p / "sweep.json").read_text())
                except (OSError, ValueError) as exc:
                    raise ConfigError(f"{flag}: {p / 'sweep.json'} cannot be read ({exc}): remove the folder or "
                                      "choose another") from None
                if not isinstance(state, dict) or state.get("format") != FORMAT:
                    raise ConfigError(f"{flag}: {p / 'sweep.json'}: not a {FORMAT} folder")
        parent = p.parent
        while not parent.exists() and parent.parent != parent:
            parent = parent.parent
        if not os.access(parent if not p.exists() else p, os.W_OK | os.X_OK):
            raise ConfigError(f"{flag}: cannot write in {p if p.exists() else parent}")

    def check_same(self, name: str, force: bool = False) -> None:
        """A folder that holds another sweep (another name) is refused unless ``force``; the same one resumes."""
        try:
            state = json.loads((self.root / "sweep.json").read_text())
        except (OSError, ValueError):
            return  # a new folder (check() refused an unreadable sweep.json)
        other = state.get("name")
        if other != name and not force:
            raise ConfigError(f"{self.flag}: {self.root} holds the sweep {other!r} ({state.get('sweep_file')}, "
                              f"{state.get('tasks')} runs), not {name!r}; pass --force to run {name!r} in it (the "
                              f"stored runs stay as a cache; the table, summary and figures are replaced) or choose "
                              f"another folder")

    def open(self, state: dict, sweep_text: str) -> None:
        """Create the folder (or take up an existing sweep folder); drop temporary files a killed sweep left."""
        self.runs.mkdir(parents=True, exist_ok=True)
        self.failed.mkdir(exist_ok=True)
        for folder in (self.root, self.runs, self.failed):
            for tmp in folder.glob(f".*{_TMP}*"):
                shutil.rmtree(tmp, ignore_errors=True) if tmp.is_dir() else tmp.unlink(missing_ok=True)
        (self.root / MARKER).write_text("written by sins-sim sweep; a later sweep resumes from it\n")
        atomic_write_text(self.root / "sweep.json", json.dumps({"format": FORMAT, **state}, indent=2) + "\n")
        atomic_write_text(self.root / "sweep.yaml", sweep_text)

    def done_keys(self) -> set:
        """Keys with a finished part."""
        return {p.stem for p in self.runs.glob("*.parquet") if not p.name.startswith(".")}

    def failed_keys(self) -> set:
        return {p.stem for p in self.failed.glob("*.json") if not p.name.startswith(".")}

    def _replace(self, folder: Path, name: str, write) -> Path:
        fd, tmp = tempfile.mkstemp(prefix=f".{name}{_TMP}", dir=folder)
        os.close(fd)
        try:
            write(tmp)
            os.replace(tmp, folder / name)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return folder / name

    def write_row(self, row: dict) -> Path:
        """One finished run as a one-row Parquet part, atomically; its failure record (if any) removed."""
        import pandas as pd

        frame = pd.DataFrame([row])
        path = self._replace(self.runs, f"{row['key']}.parquet", lambda tmp: frame.to_parquet(tmp, index=False))
        (self.failed / f"{row['key']}.json").unlink(missing_ok=True)
        return path

    def write_failure(self, record: dict) -> Path:
        text = json.dumps(record, indent=2, default=str) + "\n"
        return self._replace(self.failed, f"{record['key']}.json", lambda tmp: Path(tmp).write_text(text))

    def table(self, keys) -> "pd.DataFrame":
        """The parts of ``keys`` (those that exist) as one table."""
        import pandas as pd

        parts = [pd.read_parquet(self.runs / f"{k}.parquet") for k in keys if (self.runs / f"{k}.parquet").is_file()]
        if not parts:
            return pd.DataFrame()
        return pd.concat(parts, ignore_index=True)

    def failures(self, keys) -> list:
        out = []
        for k in keys:
            p = self.failed / f"{k}.json"
            if p.is_file():
                out.append(json.loads(p.read_text()))
        return out

    def write_table(self, frame) -> Path:
        return self._replace(self.root, "runs.parquet", lambda tmp: frame.to_parquet(tmp, index=False))

    def write_text(self, name: str, text: str) -> Path:
        return atomic_write_text(self.root / name, text)
