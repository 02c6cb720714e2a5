"""Output folders and files: checked before anything runs, written whole or not at all.

* :func:`check_out_dir` — the folder a command writes into is made (with its parents) and probed
  by creating and removing a file in it, before any run starts; a path naming a file, a path under
  a file, a read-only or virtual file system (``/proc``), a NUL or an over-long name is an
  :class:`OutputError` (one line naming the path and the reason). Permission bits alone are not
  trusted: as root they pass, so the probe writes.
* :func:`atomic_write_text` / :func:`atomic_target` — a file is written under a temporary name in
  its own folder (``.<stem>.part<suffix>``) and renamed over the final name when complete (``os.replace``
  is atomic on POSIX within one file system): a reader sees the old file or the new one, never a
  half-written one; a writer that fails leaves no ``.part`` behind.
* :func:`lock_folder` — one command at a time into a folder (a campaign's, a run's): an exclusive
  ``flock`` on the folder, released when the command ends or its process dies (even killed); a
  second command into it meanwhile is refused (:class:`FolderInUse`, one line).
* :func:`component_summary` / :func:`plain_json_problem` / :func:`json_value` — what a component
  (a plugin's included) puts into summary.json, and what would keep it from strict, repeatable JSON.
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from mjasc.core.config_tables import ConfigError, path_problem, show_path

__all__ = ["OutputError", "check_out_dir", "atomic_write_text", "atomic_target", "part_path", "json_value",
           "component_summary", "plain_json_problem", "FolderInUse", "lock_folder", "unlock_folder", "os_reason",
           "no_room", "remove_part_files", "clear_run_folder", "close_output"]


class OutputError(ConfigError):
    """An output folder or file cannot be written; the message names the path and the reason."""


def check_out_dir(path: str | Path, what: str = "--out") -> Path:
    """Make the folder ``path`` (and its parents) and prove it writable; returns it as a Path.
    Raises :class:`OutputError` ``"<what> <path>: <reason>"``."""
    if isinstance(path, str) and path == "":  # (Path("") is the current folder: never meant, and a run's clean-up there)
        raise OutputError(f"{what}: an empty name, not a folder (give '.' for the current folder)")
    shown = f"{what} {show_path(path)}"
    problem = path_problem(path)
    if problem:
        raise OutputError(f"{shown}: not a usable folder name ({problem})")
    path = Path(path)
    for parent in (path, *path.parents):
        if parent.exists() or parent.is_symlink():
            if not parent.is_dir():
                where = "is a file, not a folder" if parent == path else f"{show_path(parent)} is a file, not a folder"
                raise OutputError(f"{shown}: {where}")
            break
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".mjasc-write-probe-{os.getpid()}"
        with open(probe, "wb") as f:
            f.write(b"ok")
        probe.unlink()
    except OSError as exc:
        raise OutputError(f"{shown}: cannot write there ({exc.strerror or exc})") from None
    return path


class FolderInUse(RuntimeError):
    """Another process writes into the folder (:func:`lock_folder`)."""


_LOCKED_BY = {"campaign": "another campaign command is running into this folder; wait for it to end (then the same "
                          "command does what is left) or give another --out",
              "run": "another run is writing into this folder; wait for it to end or give another --out"}


def lock_folder(folder: Path, what: str = "campaign"):
    """Hold ``folder`` for one command (``what``: "campaign" or "run"; an exclusive ``flock`` on the
    folder itself, released by :func:`unlock_folder` or when the process ends, even killed): a
    second command started into it meanwhile — the same campaign would do every run a second time,
    two runs would write the same temporary files — is refused with :class:`FolderInUse`. Returns
    the handle (None where the file system has no such lock: as before)."""
    try:
        import fcntl
    except ImportError:  # (no flock: Windows)
        return None
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise FolderInUse(f"{folder}: {_LOCKED_BY[what]}") from None
    except OSError:  # (a file system without flock)
        os.close(fd)
        return None
    return fd


def unlock_folder(handle) -> None:
    if handle is not None:
        os.close(handle)  # (the lock goes with the last descriptor: none is inherited)


def os_reason(exc: BaseException, folder: str | Path | None = None) -> str:
    """Why writing failed, as a user reads it: an OSError's own reason (``no space left on
    device``); an error that hides it — the Rerun SDK's "File-writer thread shut down prematurely"
    after its thread hit a full disk — as ``no space left on device`` when ``folder``'s file system
    has no room left, else its type and text."""
    if getattr(exc, "reason", None):  # (said already: mjasc.runs.recording.RecordingNotWritten)
        return str(exc.reason)
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror[:1].lower() + exc.strerror[1:]
    if folder is not None and no_room(folder):
        return "no space left on device"
    return f"{type(exc).__name__}: {exc}"


#: Free bytes under which a file system counts as full (a writer failed for want of room).
FULL_DISK_BYTES = 64 * 1024


def no_room(folder: str | Path) -> bool:
    """Whether ``folder``'s file system has (almost) no room left for this process: under
    :data:`FULL_DISK_BYTES` free (the blocks reserved for root count for root)."""
    try:
        st = os.statvfs(folder)
    except (OSError, AttributeError):
        return False
    free = st.f_bfree if hasattr(os, "geteuid") and os.geteuid() == 0 else st.f_bavail
    return free * st.f_frsize < FULL_DISK_BYTES


def remove_part_files(path: str | Path) -> None:
    """Remove the temporary files of ``path`` (:func:`part_path`, and the recording's canonical
    rewrite of it, ``….canonical``) where they exist."""
    part = part_path(path)
    for stale in (part, part.with_name(part.name + ".canonical")):
        try:
            stale.unlink(missing_ok=True)
        except OSError:
            pass


def clear_run_folder(folder: Path, names) -> None:
    """Make ``folder`` hold no earlier run's outputs (``names``, the summary last) before a run
    writes into it: the temporary files of those names a run killed there left (no run writes into
    the folder now, it is locked: :func:`lock_folder`) and, when it holds an earlier run's
    ``summary.json``, that run's outputs — the summary last, so that a clean-up cut short still
    marks what is left as a run's. Files of those names in a folder without a run's summary are
    not a run's: they stay."""
    for name in names:
        remove_part_files(folder / name)
    if (folder / "summary.json").is_file():
        for name in names:
            (folder / name).unlink(missing_ok=True)


def close_output(out) -> str | None:
    """Close a run's recording or video ``out`` (with a ``path``); None, or why its file could not
    be written — its temporary files then removed: nothing half-written is left."""
    try:
        out.close()
        return None
    except Exception as exc:  # noqa: BLE001 - a full disk, a failing encoder: the summary says so
        remove_part_files(out.path)
        return f"{out.path}: {os_reason(exc, out.path.parent)} (not written)"


def part_path(path: str | Path) -> Path:
    """The temporary name a file is written under: ``<folder>/.<stem>.part<suffix>`` (the suffix
    kept: encoders choose the format by it)."""
    path = Path(path)
    return path.with_name(f".{path.stem}.part{path.suffix}")


@contextmanager
def atomic_target(path: str | Path) -> Iterator[Path]:
    """``with atomic_target(p) as tmp:`` write ``tmp``; on a normal exit it is renamed to ``p``, on
    an exception it is removed (and the exception goes on)."""
    path = Path(path)
    tmp = part_path(path)
    try:
        yield tmp
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` under a temporary name, flushed to disk, then rename it."""
    with atomic_target(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
    return Path(path)


def component_summary(comp) -> dict:
    """A component's ``summary()`` for summary.json: what it returns (numpy numbers and arrays as
    JSON numbers and lists, :func:`json_value`) with its ``method`` first when it has one and the
    summary does not say it, or — a plugin's summary that raises, is not a dict or holds what
    summary.json cannot hold as it is (:func:`plain_json_problem`: NaN or ±inf,
    which strict JSON readers refuse; an object written as its text, a memory address that differs
    between two runs of one seed) — the method and the error, so that the run's summary is written
    all the same."""
    method = getattr(comp, "method", type(comp).__name__)
    try:
        out = comp.summary()
    except Exception as exc:  # noqa: BLE001 — a plugin's bug must not cost the run its summary
        return {"method": method, "summary_error": f"{type(exc).__name__}: {exc}"}
    if not isinstance(out, dict):
        return {"method": method, "summary_error": f"summary() returned {type(out).__name__}, expected a dict"}
    problem = plain_json_problem(out)
    if problem is not None:
        return {"method": method, "summary_error": f"summary() {problem}"}
    if "method" not in out and isinstance(getattr(comp, "method", None), str):
        out = {"method": method, **out}
    return out


def plain_json_problem(value, where: str = "") -> str | None:
    """What keeps ``value`` (a summary's dict) from being written to JSON as it is, with where it is
    (``"holds NaN at ['a'][0]"``), or None: NaN and ±inf (strict JSON readers refuse them) and any
    object but a dict with string keys, a list or tuple, a string, a number, a bool, None or a
    numpy number or array (anything else would be written as its text, which may hold a memory
    address: not the same in two runs of one seed)."""
    import math

    import numpy as np

    if value is None or isinstance(value, (str, bool, int, np.bool_, np.integer)):
        return None
    if isinstance(value, (float, np.floating)):
        return None if math.isfinite(value) else f"holds {value} at {where or 'the top'}"
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "biu":
            return None
        if value.dtype.kind == "f":
            bad = np.flatnonzero(~np.isfinite(value.ravel()))
            return None if bad.size == 0 else f"holds {value.ravel()[bad[0]]} in the array at {where or 'the top'}"
    elif isinstance(value, dict):
        for k, v in value.items():
            if not isinstance(k, str):
                return f"has the key {k!r} (not a string) at {where or 'the top'}"
            problem = plain_json_problem(v, f"{where}[{k!r}]")
            if problem is not None:
                return problem
        return None
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            problem = plain_json_problem(v, f"{where}[{i}]")
            if problem is not None:
                return problem
        return None
    return f"holds a {type(value).__name__} at {where or 'the top'} (only numbers, strings, bools, None, lists " \
           f"and dicts go into summary.json)"


def json_value(value):
    """``json.dumps(..., default=json_value)``: numpy scalars as numbers, arrays as lists, any other
    object as its text (a plugin's summary holding one is written as its error instead:
    :func:`plain_json_problem`, docs/plugins.md)."""
    import numpy as np

    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)
