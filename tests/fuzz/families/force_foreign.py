"""``--force`` onto an existing result folder (issue 40): a folder holding only what sins-sim wrote (its marker lists
every file, or for an older folder its ``manifest.json``) is replaced; one that also holds a file of the user's, has no readable manifest
or no output marker is refused in one line naming ``--out`` (and the files), and left as it was."""

from __future__ import annotations

import json
from pathlib import Path

from . import Family, Made
from ._listed import pick

MARKER = ".sins-sim-output"
OURS = {"metrics.json": b"{}\n", "channel.png": b"\x89PNG", "timeseries.npz": b"PK"}


def _folder(extra: dict | None = None, manifest="listed", marker=True, listed=False) -> dict:
    files = {f"out/{k}": v for k, v in OURS.items()}
    if marker:
        files[f"out/{MARKER}"] = b"written by sins-sim\n" + b"".join(
            f"file: {k}\n".encode() for k in (OURS if listed else ()))
    if manifest == "listed":
        files["out/manifest.json"] = json.dumps({"command": "channel", "outputs": {k: "0" for k in OURS}}).encode()
    elif manifest == "corrupt":
        files["out/manifest.json"] = b"{not json"
    elif manifest == "no_outputs":
        files["out/manifest.json"] = json.dumps({"command": "channel"}).encode()
    files.update({f"out/{k}": v for k, v in (extra or {}).items()})
    return files


#: (class, expect, what, files)
_CASES = [
    ("force_ours", "valid", "a folder of sins-sim's files only", _folder()),
    ("force_ours", "valid", "the files listed by the marker", _folder(manifest=None, listed=True)),
    ("force_foreign", "invalid", "a file beside those the marker lists",
     _folder({"notes.txt": b"keep\n"}, manifest=None, listed=True)),
    ("force_foreign", "invalid", "notes.txt beside the result", _folder({"notes.txt": b"keep\n"})),
    ("force_foreign", "invalid", "a user's figure in a sub-folder", _folder({"mine/fig.png": b"\x89PNG"})),
    ("force_foreign", "invalid", "a user's hidden file", _folder({".notes": b"keep\n"})),
    ("force_foreign", "invalid", "a manifest that is not JSON", _folder(manifest="corrupt")),
    ("force_foreign", "invalid", "a manifest without outputs", _folder(manifest="no_outputs")),
    ("force_foreign", "invalid", "no manifest", _folder(manifest=None)),
    ("force_foreign", "invalid", "no output marker (a user's folder)", _folder(marker=False)),
]


def _made(cls, expect, what, files):
    return lambda: Made(cls, expect, f"--force: {what}", dict(files))


CASES = [_made(*c) for c in _CASES]


def _validate(folder: Path) -> None:
    from sins_sim.jobs.output import check_out_dir

    check_out_dir(folder / "out", "--out", min_free_bytes=0, force=True)


FAMILY = Family(kind="force_foreign", weight=0.02, classes=("force_ours", "force_foreign"),
                make=lambda rng: pick(CASES, rng),
                command=lambda folder: ["channel", "--duration", "0.3", "--out", str(folder / "out"), "--force",
                                        "--quiet"],
                validate=_validate)
