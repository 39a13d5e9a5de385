"""The sweep's folder: results as they finish, atomically, and what a resumed sweep finds there.

Layout of ``--out DIR``::

    DIR/
      .sins-sim-output       marker: a folder sins-sim wrote
      sweep.json             what the folder holds (format, sweep name and file, version, tasks)
      sweep.yaml             a copy of the sweep file as run
      runs/<key>.parquet     a part: the row of one finished run, written as its task finishes
      runs/<key>-<n>.parquet a part of n rows: the runs of one Dask task of n runs (<key>: its first run's)
      failed/<key>.json      a failed run: unit, scenario, drawn parameters, error and traceback
      runs.parquet           the sweep's table: this sweep's parts in (scenario, unit) order
      summary.json           runs, failed, percentiles of every metric per filter
      *.png                  distributions and sensitivities

Each part is written to a hidden temporary file in ``runs/`` and renamed into place (``os.replace``),
so a part is complete or absent; an interrupted sweep leaves finished parts behind and a resumed one
runs only the keys without a part (a task's runs are stored when the task finishes, so whether they share a part
or not the resume loses the same). A task of several runs is one part: one Parquet file per run costs the client
about 11 ms of CPU (mostly Parquet's metadata of the 100-odd columns), a part of 20 rows about 0.3 ms per row, and
the worker packs it (:func:`pack_rows`), so the client only writes the bytes. ``runs/`` is a cache keyed by run:
parts of an earlier definition of the sweep stay there but are not in ``runs.parquet``. Failed runs are tried again on a resume.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from pathlib import Path

from sins_sim.jobs.output import MARKER, atomic_write_text
from sins_sim.config.errors import ConfigError

__all__ = ["SweepStore", "FORMAT", "pack_rows"]

#: The ``format`` of ``sweep.json``.
FORMAT = "sins-sim-sweep/1"
_TMP = ".tmp-"
#: A run's key (:func:`sins_sim.jobs.sweep.tasks.run_key`): the name of a one-row part.
_KEY = re.compile(r"[0-9a-f]{20}")


def pack_rows(rows: list) -> bytes:
    """Rows (dicts) as the bytes of one Parquet file: columns in the order of their first appearance, a key
    missing from a row is null there (NaN once read into pandas), as ``pandas.DataFrame(rows)`` would give."""
    import io

    import pyarrow as pa
    import pyarrow.parquet as pq

    names = list(dict.fromkeys(k for r in rows for k in r))
    table = pa.table({n: pa.array([r.get(n) for r in rows]) for n in names})
    buf = io.BytesIO()
    pq.write_table(table, buf)
    return buf.getvalue()


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

    def _parts(self) -> list:
        return sorted(p for p in self.runs.glob("*.parquet") if not p.name.startswith("."))

    @staticmethod
    def _part_keys(path: Path) -> list:
        """The keys of a part: its name for a one-row part, else its ``key`` column."""
        if _KEY.fullmatch(path.stem):
            return [path.stem]
        import pandas as pd

        return list(pd.read_parquet(path, columns=["key"])["key"])

    def done_keys(self) -> set:
        """Keys with a finished part."""
        return {k for p in self._parts() for k in self._part_keys(p)}

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

    def write_part(self, data: bytes, keys: list) -> Path:
        """A part (:func:`pack_rows` of the rows of ``keys``, in that order), atomically; the runs' failure records
        (if any) removed. Named ``<key>.parquet`` for one run, ``<first key>-<n>.parquet`` for n."""
        name = f"{keys[0]}.parquet" if len(keys) == 1 else f"{keys[0]}-{len(keys)}.parquet"
        path = self._replace(self.runs, name, lambda tmp: Path(tmp).write_bytes(data))
        for k in keys:
            (self.failed / f"{k}.json").unlink(missing_ok=True)
        return path

    def write_row(self, row: dict) -> Path:
        """One finished run as a one-row part (:meth:`write_part`)."""
        return self.write_part(pack_rows([row]), [row["key"]])

    def stored_row(self, key: str):
        """``(path, row as a dict)`` of the part that holds ``key``, or None."""
        import pandas as pd

        one = self.runs / f"{key}.parquet"
        for p in [one] if one.is_file() else [p for p in self._parts() if key in self._part_keys(p)][:1]:
            frame = pd.read_parquet(p)
            return p, frame[frame["key"] == key].iloc[0].to_dict()
        return None

    def write_failure(self, record: dict) -> Path:
        text = json.dumps(record, indent=2, default=str) + "\n"
        return self._replace(self.failed, f"{record['key']}.json", lambda tmp: Path(tmp).write_text(text))

    def table(self, keys) -> "pd.DataFrame":
        """The rows of ``keys`` (those stored), in the order of ``keys``, as one table."""
        import pandas as pd

        order = {k: i for i, k in enumerate(keys)}
        parts = []
        for p in self._parts():
            if _KEY.fullmatch(p.stem) and p.stem not in order:
                continue  # a one-row part of another sweep definition: not read
            frame = pd.read_parquet(p)
            frame = frame[frame["key"].isin(order)]
            if len(frame):
                parts.append(frame)
        if not parts:
            return pd.DataFrame()
        table = pd.concat(parts, ignore_index=True).drop_duplicates("key")  # equal keys: equal rows
        return table.iloc[table["key"].map(order).argsort(kind="stable")].reset_index(drop=True)

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
