"""Output that cannot lie: results appear complete, atomically, or not at all.

A job writes into a temporary sibling of its target; only when it finishes
is the sibling renamed into place. An interrupted or failed run (an
exception, Ctrl-C, SIGTERM) leaves no partial folder behind and leaves the
results of an earlier run untouched, and the results of two runs are never
mixed in one folder.

- :func:`check_out_dir`, :func:`check_out_file`: is the target usable? Checked
  before any computation; a broken rule is one :class:`ConfigError` line naming
  the flag (``--out``, ``--json``, ...) and the rule.
- :func:`atomic_output_dir`: a context manager yielding the directory to write into.
  On success it takes the target's place; an earlier result folder is moved aside
  and deleted only after the new one is in place.
- :func:`atomic_output_file`: the same for a single file (``--json x.json``, ``--out rec.npz``).
- :func:`atomic_write_bytes`, :func:`atomic_write_text`: write a file in one step
  (temporary file in the same folder, then ``os.replace``).

A folder that sins-sim wrote carries the marker file :data:`MARKER` (and its
``manifest.json``, :mod:`sins_sim.jobs.manifest`). An existing, non-empty
target folder is never replaced silently: without ``force`` (the ``--force``
flag) it is refused with one line naming the flag, the folder and what it
holds (the command, scenario and date from its manifest); with ``force`` an
earlier sins-sim result is replaced once the new one is complete. A folder
without the marker is refused even with ``force``: ``--out .`` or ``--out ~``
must not delete what is there.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

from sins_sim.config.errors import ConfigError

__all__ = ["MARKER", "MIN_FREE_BYTES", "foreign_files", "check_out_dir", "check_out_file", "atomic_output_dir",
           "atomic_output_file", "atomic_write_bytes", "atomic_write_text"]

#: File that marks a folder as a sins-sim result (so that a later run with ``--force`` may replace it).
MARKER = ".sins-sim-output"
#: The marker's first line; then one ``file: <relative path>`` line per file sins-sim wrote into the folder (what a
#: later ``--force`` may replace: :func:`foreign_files`).
MARKER_TEXT = "written by sins-sim; a later run with --force may replace the files listed below (and only them)\n"
_LISTED = "file: "
#: Free space (bytes) required where an output goes: room for a few plots and arrays.
MIN_FREE_BYTES = 16 * 2 ** 20


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _existing_ancestor(path: Path, flag: str) -> Path:
    """The nearest existing ancestor of ``path`` (which must be a directory we may write into)."""
    parent = path.parent
    while not parent.exists():
        if parent.is_symlink():  # a dangling symlink: cannot be created through
            raise ConfigError(f"{flag}: cannot create {path}: {parent} is a broken symbolic link")
        if parent.parent == parent:
            break
        parent = parent.parent
    if not parent.is_dir():
        raise ConfigError(f"{flag}: cannot create {path}: {parent} exists and is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(f"{flag}: cannot create {path}: no permission to write in {parent}")
    return parent


def _check_space(where: Path, path: Path, flag: str, min_free_bytes: int) -> None:
    try:
        usage = shutil.disk_usage(where)
    except OSError:  # some file systems cannot tell; writing will say
        return
    free = usage.free
    if usage.total == 0:  # procfs, sysfs: no room for files at all
        raise ConfigError(f"{flag}: cannot create {path}: {where} is a virtual file system with no storage for files")
    if free < min_free_bytes:
        raise ConfigError(f"{flag}: not enough free disk space for {path}: {free / 2 ** 20:.1f} MiB free in "
                          f"{where}, need at least {min_free_bytes / 2 ** 20:.1f} MiB")


def _target(path, flag: str, what: str) -> Path:
    if path is None or not str(path).strip():
        raise ConfigError(f"{flag}: must name {what}, got {str(path or '')!r}")
    p = Path(os.path.expanduser(str(path)))
    if p.is_symlink() and p.exists():  # write where the link points, keep the link
        p = p.resolve()
    return p


def _inside(path: Path, folder: Path) -> bool:
    path, folder = os.path.abspath(path), os.path.abspath(folder)
    return os.path.commonpath([path, folder]) == folder


def check_out_dir(path, flag: str = "--out", min_free_bytes: int = MIN_FREE_BYTES, inputs=(),
                  force: bool = False) -> Path:
    """Check that ``path`` can become a result folder; return it as a Path.

    Rules: not empty; not an existing file; if an existing folder, either
    empty, or written by sins-sim (it holds :data:`MARKER`), ``force``
    given and every file in it listed as sins-sim's (:func:`foreign_files`:
    a file the user added is never replaced), and holding
    neither the current directory nor any of ``inputs`` (it is replaced as a
    whole); its parent exists or can be created, and can be written to; at
    least ``min_free_bytes`` free there. Nothing is created.

    Parameters
    ----------
    path : str or Path
        The result folder.
    flag : str
        The command-line flag that named it (for error messages).
    min_free_bytes : int
        Free space required where it goes.
    inputs : iterable of paths
        Files the job reads, which must not live inside the folder.
    force : bool
        Replace an earlier sins-sim result (the user said ``--force``).

    Raises
    ------
    ConfigError
        ``"<flag>: <rule>"``, one line.
    """
    p = _target(path, flag, "a directory")
    if p.exists() or p.is_symlink():
        if not p.is_dir():
            raise ConfigError(f"{flag}: {p} exists and is not a directory")
        real = p.resolve()
        if real == Path(real.anchor) or _inside(Path.cwd().resolve(), real):
            raise ConfigError(f"{flag}: {p} is the root, the current directory or one holding it; the results "
                              "folder is replaced as a whole: name a folder of its own")
        for item in inputs:
            if item is not None and _inside(Path(item).resolve(), real):
                raise ConfigError(f"{flag}: {p} holds the input {item}, and the results folder is replaced as a "
                                  "whole: move the input or choose another folder")
        try:
            entries = os.listdir(p)
        except OSError as exc:
            raise ConfigError(f"{flag}: {p} cannot be listed ({exc.strerror})") from None
        if entries and MARKER not in entries:
            raise ConfigError(f"{flag}: {p} exists and holds files that sins-sim did not write (no {MARKER}); "
                              "remove it or choose another directory (--force does not replace it)")
        if entries and not force:
            from sins_sim.jobs.manifest import describe_folder

            raise ConfigError(f"{flag}: {p} already holds {describe_folder(p)}; pass --force to replace it (once "
                              "the new result is complete) or choose another folder")
        if entries:  # --force replaces what sins-sim wrote, never a file it did not write
            foreign = foreign_files(p)
            if foreign is None:
                raise ConfigError(f"{flag}: {p} holds no list of the files sins-sim wrote there (its {MARKER} and "
                                  "manifest.json list none: an older sins-sim's result), so --force cannot tell them "
                                  "from yours; remove the folder yourself or choose another one")
            if foreign:
                shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
                raise ConfigError(f"{flag}: {p} also holds files sins-sim did not write ({shown}); --force replaces "
                                  "only a sins-sim result: move them out or choose another folder (nothing was "
                                  "changed)")
    parent = _existing_ancestor(p, flag)
    _check_space(parent, p, flag, min_free_bytes)
    return p


def check_out_file(path, flag: str, min_free_bytes: int = MIN_FREE_BYTES) -> Path:
    """Check that ``path`` can be written as a single output file; return it as a Path.

    Rules: not empty; not an existing directory or special file (a device, a
    pipe); its folder exists or can be created, and can be written to; at
    least ``min_free_bytes`` free there. Nothing is created.

    Raises
    ------
    ConfigError
        ``"<flag>: <rule>"``, one line.
    """
    p = _target(path, flag, "a file")
    if p.exists():
        if p.is_dir():
            raise ConfigError(f"{flag}: {p} is a directory, not a file")
        if not p.is_file():
            raise ConfigError(f"{flag}: {p} exists and is not a regular file")
    parent = _existing_ancestor(p, flag)
    _check_space(parent, p, flag, min_free_bytes)
    return p


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        try:
            path.unlink()
        except OSError:
            pass


@contextmanager
def atomic_output_dir(out_path, flag: str = "--out", min_free_bytes: int = MIN_FREE_BYTES, inputs=(),
                      force: bool = False):
    """Give a job a temporary folder; on success it becomes ``out_path``.

    Parameters
    ----------
    out_path : str or Path
        The result folder.
    flag : str
        The command-line flag that named it (for error messages).
    min_free_bytes : int
        Free space required beside it.
    inputs : iterable of paths
        Files the job reads (they must not live inside an existing ``out_path``).
    force : bool
        Replace an earlier sins-sim result at ``out_path`` (default: refuse it).

    Yields
    ------
    Path
        An empty temporary folder beside ``out_path`` (same file system).

    Raises
    ------
    ConfigError
        When the target is not usable (:func:`check_out_dir`), before the job runs.

    Notes
    -----
    On success the temporary folder is renamed to ``out_path``. An earlier
    result folder there (only with ``force``) is first renamed aside, and deleted only after the new
    one is in place. On any exception (``KeyboardInterrupt`` included) the
    temporary folder is removed and ``out_path`` is left as it was.
    """
    target = check_out_dir(out_path, flag, min_free_bytes, inputs, force)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.tmp-", dir=target.parent))
    except OSError as exc:
        raise ConfigError(f"{flag}: cannot create {target}: {exc.strerror or exc}") from None
    try:
        yield tmp
        written = sorted(q.relative_to(tmp).as_posix() for q in tmp.rglob("*") if not q.is_dir())
        (tmp / MARKER).write_text(MARKER_TEXT + "".join(f"{_LISTED}{rel}\n" for rel in written))
        os.chmod(tmp, 0o777 & ~_umask())
        _commit_dir(tmp, target)
    except BaseException:
        _remove(tmp)
        raise


def foreign_files(folder) -> list | None:
    """Files in a sins-sim result folder that sins-sim did not write, as sorted relative paths.

    What sins-sim wrote is what the folder's :data:`MARKER` lists (one ``file: <path>`` line per file it wrote),
    else, for a folder written before the marker listed them, what its ``manifest.json`` lists under ``outputs``;
    the marker and the manifest themselves are sins-sim's. ``None`` when neither lists anything (then nothing can
    be told apart).
    """
    folder = Path(folder)
    try:
        ours = {ln[len(_LISTED):] for ln in (folder / MARKER).read_text().splitlines() if ln.startswith(_LISTED)}
    except (OSError, UnicodeDecodeError):
        ours = set()
    if not ours:
        try:
            outputs = json.loads((folder / "manifest.json").read_text()).get("outputs")
        except (OSError, UnicodeDecodeError, ValueError, AttributeError):
            outputs = None
        if not isinstance(outputs, dict):
            return None
        ours = set(outputs) | {"manifest.json"}
    ours.add(MARKER)
    return sorted(rel for q in folder.rglob("*") if not q.is_dir()
                  and (rel := q.relative_to(folder).as_posix()) not in ours)


def _commit_dir(tmp: Path, target: Path) -> None:
    """Rename ``tmp`` to ``target``; an existing ``target`` goes aside first and is deleted last."""
    if not (target.exists() or target.is_symlink()):
        os.rename(tmp, target)
        return
    aside = Path(tempfile.mkdtemp(prefix=f".{target.name}.old-", dir=target.parent))
    old = aside / target.name
    os.rename(target, old)
    try:
        os.rename(tmp, target)
    except BaseException:
        os.rename(old, target)  # put the earlier result back
        os.rmdir(aside)
        raise
    shutil.rmtree(aside, ignore_errors=True)


@contextmanager
def atomic_output_file(out_path, flag: str, min_free_bytes: int = MIN_FREE_BYTES):
    """Give a job a temporary file path; on success it replaces ``out_path``.

    Parameters
    ----------
    out_path : str or Path
        The file to write.
    flag : str
        The command-line flag that named it (for error messages).
    min_free_bytes : int
        Free space required beside it.

    Yields
    ------
    Path
        An empty file beside ``out_path`` with the same suffix. On success it
        is renamed over ``out_path`` (``os.replace``); on any exception it is
        removed and ``out_path`` is left as it was. A job that wrote nothing
        there leaves ``out_path`` untouched.

    Raises
    ------
    ConfigError
        When the target is not usable (:func:`check_out_file`), before the job runs.
    """
    target = check_out_file(out_path, flag, min_free_bytes)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(prefix=f".{target.name}.tmp-", suffix=target.suffix, dir=target.parent)
    except OSError as exc:
        raise ConfigError(f"{flag}: cannot create {target}: {exc.strerror or exc}") from None
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        if tmp.exists() and tmp.stat().st_size > 0:
            os.chmod(tmp, 0o666 & ~_umask())
            os.replace(tmp, target)
        else:
            tmp.unlink()
    except BaseException:
        _remove(tmp)
        raise


def atomic_write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` in one step: a temporary file beside it, then ``os.replace``.

    Readers see the old content or the new one, never a part; a failure
    leaves the old file as it was. The folder is created if needed.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.tmp-", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(name, 0o666 & ~_umask())
        os.replace(name, path)
    except BaseException:
        try:
            os.unlink(name)
        except OSError:
            pass
        raise
    return path


def atomic_write_text(path, text: str, encoding: str = "utf-8") -> Path:
    """:func:`atomic_write_bytes` for text."""
    return atomic_write_bytes(path, text.encode(encoding))
