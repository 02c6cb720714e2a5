"""Own hulls shipped to the runs' workers: a campaign runs where the hull folder is not.

A run's scenario names a vessel folder by the absolute path the driver resolved it to
(``type = "/srv/lab/hulls/heron"``). A worker on another machine has no such folder, so the driver
reads each folder the runs to do name once, before anything is written (:func:`pack_hulls`: the
files runs read, :mod:`mjasc.physics.hull_files`, content as text-safe base64, keyed by a SHA-256
of every file's path and bytes), and the packs go to each Dask worker once (a task's result its
runs depend on, :func:`ship_to_cluster`; the threads of a local cluster and an in-process campaign
share the driver's). The process
that hands a run to its child (or runs it) writes each pack once (:func:`localise`) into a private
temporary folder (``<tmp>/mjasc-hulls-<host>-<pid>-XXXX/<key>/<name>/``, mode 0700; written under
another name and renamed when complete, so a folder there is always whole; reused by every later
run; removed when the last campaign of the process that uses them ends, :func:`release_hull_root`,
or at the process's exit; one a killed process left is removed when another process of the host
makes its own) and maps the driver's path to it; the run's scenario then names the local copy
(:func:`with_vessel_paths`). The folder keeps its name, so the
vessel's type name, its model and every result are those of a run from the original folder, bit
for bit; the stored scenario text still names the original path (``mjasc extract`` replays it
where that folder is). A built-in hull (``type = "otter"``) ships nothing.
"""

from __future__ import annotations

import atexit
import base64
import glob
import hashlib
import os
import re
import shutil
import socket
import tempfile
import threading
from pathlib import Path, PurePosixPath

from mjasc.physics.hull_files import content_hashes, fingerprint, is_folder_type, read_folder

__all__ = ["run_vessel_types", "pack", "pack_hulls", "ship_to_cluster", "localise", "run_document",
           "with_vessel_paths", "hold_hull_root", "release_hull_root", "remove_hull_root", "HULL_ROOT_PREFIX"]

#: The prefix of a process's temporary folder of shipped hulls.
HULL_ROOT_PREFIX = "mjasc-hulls-"
_ROOT: Path | None = None
_USERS = 0  # campaigns of this process that sail shipped hulls now (hold_hull_root)
_LOCK = threading.Lock()
_KEY = re.compile(r"[0-9a-f]{64}")  # (a pack's key names its folder here: nothing else may)


def run_vessel_types(scenario_toml: str) -> list[tuple[int, str, str]]:
    """``(index, name, type)`` of each vessel of a run's scenario text (the type as resolved: a
    built-in name or a folder's absolute path)."""
    import tomllib

    vessels = tomllib.loads(scenario_toml).get("vessels", [])
    return [(i, str(v.get("name", f"v{i}")), str(v.get("type", ""))) for i, v in enumerate(vessels)
            if isinstance(v, dict)]


def pack(folder: str) -> dict:
    """One vessel folder read into a pack: ``{"name", "key", "fingerprint", "files": {path: base64}}``
    (``key``: SHA-256 of the files' paths and bytes; ``fingerprint``: the report's content tag).
    Raises ValueError (one line naming the file and the reason)."""
    name = Path(folder).name
    files = read_folder(folder)
    h = hashlib.sha256()
    for rel in sorted(files):
        h.update(rel.encode() + b"\0" + len(files[rel]).to_bytes(8, "little") + files[rel])
    return {"name": name, "key": h.hexdigest(), "fingerprint": fingerprint(content_hashes(name, files)),
            "files": {rel: base64.b64encode(data).decode("ascii") for rel, data in files.items()}}


def pack_hulls(runs) -> dict[str, dict]:
    """``{folder's absolute path: pack}`` for every vessel folder the ``runs`` (RunSpecs) sail,
    each read once; {} when they sail built-in hulls only. Raises CampaignError naming the run's
    family, the vessel's field, the file and the reason (a folder gone or broken since the
    campaign was read)."""
    from mjasc.campaigns.perturbation import CampaignError

    packs: dict[str, dict] = {}
    for run in runs:
        text = run.scenario_toml
        if f'type = "{os.sep}' not in text:  # (no vessel folder: nothing to parse)
            continue
        for i, _, vtype in run_vessel_types(text):
            if is_folder_type(vtype) and vtype not in packs:
                try:
                    packs[vtype] = pack(vtype)
                except (ValueError, OSError) as exc:
                    raise CampaignError(f"family {run.family!r} (run {run.index}) vessels[{i}].type: {exc}") from None
    return packs


def _shipped(packs: dict) -> dict:
    return packs


def ship_to_cluster(client, packs: dict, tag: str):
    """The packs as the Dask future every run's task depends on: a task's result, which each
    worker fetches once when its first run needs it. Not scattered data, which a worker lost with
    its only copy (killed, restarted by its nanny) takes with it: every run depending on it is then
    cancelled, retries too. A task's result is computed again (its input stays with the scheduler)."""
    import warnings

    with warnings.catch_warnings():  # (a large mesh: Dask's notice of a large graph; it is sent once)
        warnings.simplefilter("ignore", UserWarning)
        return client.submit(_shipped, packs, pure=False, key=f"mjasc-hulls-{tag}")


def _owner_tag() -> str:
    """``<host>-`` (the host name with ``-`` and anything unusual as ``_``): a process's folder is
    ``<tmp>/mjasc-hulls-<host>-<pid>-XXXX``."""
    return re.sub(r"[^A-Za-z0-9.]", "_", socket.gethostname()) + "-"


def _sweep_stale() -> None:
    """Remove the folders of shipped hulls that processes of this host and user killed before they
    could (SIGKILL, SIGTERM, out of memory) left behind: those whose process no longer runs."""
    prefix = HULL_ROOT_PREFIX + _owner_tag()
    for path in Path(tempfile.gettempdir()).glob(f"{glob.escape(prefix)}*"):
        pid = path.name[len(prefix):].split("-", 1)[0]
        try:
            if not pid.isdigit() or path.lstat().st_uid != os.getuid() or int(pid) == os.getpid():
                continue
            os.kill(int(pid), 0)
        except ProcessLookupError:  # (gone: its copies are no run's any more)
            shutil.rmtree(path, ignore_errors=True)
        except OSError:  # (alive under another user, or the folder went meanwhile)
            continue


def _root() -> Path:
    """This process's folder of shipped hulls (made on first use, when the stale ones go)."""
    global _ROOT
    if _ROOT is None or not _ROOT.is_dir():
        _sweep_stale()
        _ROOT = Path(tempfile.mkdtemp(prefix=f"{HULL_ROOT_PREFIX}{_owner_tag()}{os.getpid()}-"))
        atexit.register(shutil.rmtree, str(_ROOT), True)
    return _ROOT


def _materialise(p: dict) -> str:
    """The local copy of pack ``p`` (written now if this process has none): its folder's path."""
    key, name = str(p.get("key", "")), str(p.get("name", ""))
    if not _KEY.fullmatch(key) or name in ("", ".", "..") or "/" in name or os.sep in name:
        raise ValueError(f"shipped hull {name!r}: not a pack (a SHA-256 key and a folder name), got key {key!r}")
    with _LOCK:
        root = _root()
    final = root / p["key"]
    folder = final / p["name"]
    if folder.is_dir():
        return str(folder)
    staging = Path(tempfile.mkdtemp(prefix=f".{p['key'][:16]}-", dir=root))
    try:
        h = hashlib.sha256()
        for rel in sorted(p["files"]):
            parts = PurePosixPath(rel).parts
            if PurePosixPath(rel).is_absolute() or ".." in parts or not parts:
                raise ValueError(f"shipped hull {p['name']}: not a path inside its folder, got {rel!r}")
            data = base64.b64decode(p["files"][rel])
            h.update(rel.encode() + b"\0" + len(data).to_bytes(8, "little") + data)
            target = staging / p["name"] / Path(*parts)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        if h.hexdigest() != p["key"]:
            raise ValueError(f"shipped hull {p['name']}: its files do not match their key (damaged on the way)")
        try:
            os.rename(staging, final)
        except OSError:  # (another thread of this process wrote it meanwhile: the same content)
            if not folder.is_dir():
                raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return str(folder)


def localise(request: dict) -> dict:
    """A run request whose ``hulls`` (packs by the driver's path) are written here (module
    docstring): the request without them, with ``vessel_paths`` ``{driver's path: local path}``.
    A request without ``hulls`` is returned as it is."""
    hulls = request.get("hulls")
    if not hulls:
        return request
    out = {k: v for k, v in request.items() if k != "hulls"}
    out["vessel_paths"] = {**(request.get("vessel_paths") or {}),
                           **{path: _materialise(p) for path, p in hulls.items()}}
    return out


def run_document(request: dict) -> tuple[dict, dict, object]:
    """A run request (:mod:`mjasc.campaigns.executor`) with its shipped hulls written here
    (:func:`localise`), its scenario document, which sails the local copies, and that document
    parsed — the Scenario whose ``raw`` is still the document as written (a recording's scenario
    text names the driver's folder, as a run from the folder does, not this process's copy)."""
    import tomllib
    from dataclasses import replace

    from mjasc.runs.scenario import parse_scenario

    request = localise(request)
    written = tomllib.loads(request["scenario_toml"])
    doc = with_vessel_paths(written, request.get("vessel_paths"))
    sc = parse_scenario(doc, f"<run {request.get('index')}>")
    return request, doc, sc if doc is written else replace(sc, raw=written)


def with_vessel_paths(doc: dict, vessel_paths: dict | None) -> dict:
    """A scenario document whose vessels sail the local copies ``vessel_paths`` maps their
    folders to (the document itself when none applies)."""
    vessels = doc.get("vessels")
    if not vessel_paths or not isinstance(vessels, list):
        return doc
    if not any(isinstance(v, dict) and v.get("type") in vessel_paths for v in vessels):
        return doc
    return {**doc, "vessels": [{**v, "type": vessel_paths[v["type"]]}
                               if isinstance(v, dict) and v.get("type") in vessel_paths else v for v in vessels]}


def hold_hull_root() -> None:
    """A campaign of this process starts sailing shipped hulls: its copies stay until it releases them."""
    global _USERS
    with _LOCK:
        _USERS += 1


def release_hull_root() -> None:
    """A campaign of this process has ended: the copies are removed once no other one runs here."""
    global _USERS, _ROOT
    with _LOCK:  # (the last user and the folder's removal decided at once: a campaign starting now makes a new one)
        _USERS = max(0, _USERS - 1)
        root = None
        if _USERS == 0:
            root, _ROOT = _ROOT, None
    if root is not None:
        shutil.rmtree(root, ignore_errors=True)


def remove_hull_root() -> None:
    """Remove this process's shipped hulls (the campaign has ended: no run reads them any more)."""
    global _ROOT
    with _LOCK:
        root, _ROOT = _ROOT, None
    if root is not None:
        shutil.rmtree(root, ignore_errors=True)
