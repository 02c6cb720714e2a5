"""The files of a vessel folder that runs read, and a fingerprint of their content.

A vessel folder ``<name>/`` (assets/README.md, "Your own hull") is read through ``<name>.xml`` and
``hydrodynamics.toml``, and through whatever the MJCF references: ``<mesh>``, ``<skin>``,
``<hfield>`` and ``<texture>`` files (under the ``<compiler>``'s ``meshdir`` / ``texturedir`` /
``assetdir``) and ``<include>`` / ``<model>`` files, all relative to the MJCF's folder as MuJoCo
resolves them. :func:`folder_files` lists them (relative to the folder: what a campaign ships to
workers that do not have the folder, :mod:`mjasc.campaigns.hull_shipping`); :func:`content_hashes`
hashes their content as the campaign digest covers it — the TOML as parsed and the MJCF in
canonical form without comments (a comment is not a new campaign), every other file byte for byte
— and :func:`fingerprint` makes of those hashes the short tag a report names a hull by (two
folders of one name with different hulls differ; the same hull in two places is the same).
"""

from __future__ import annotations

import hashlib
import json
import os
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

__all__ = ["HULL_FILES", "referenced_files", "folder_files", "read_folder", "content_hashes", "fingerprint",
           "is_folder_type", "FINGERPRINT_CHARS"]

#: The two files every vessel folder holds besides what its MJCF references ("{name}": the folder's name).
HULL_FILES = ("{name}.xml", "hydrodynamics.toml")
#: How many hex digits of the content hash a report shows (48 bits: two hulls collide once in ~10¹⁴).
FINGERPRINT_CHARS = 12
_FILE_ATTRIBUTES = ("file", "fileright", "fileleft", "fileup", "filedown", "filefront", "fileback")
_DIR_OF = {"mesh": "meshdir", "skin": "meshdir", "hfield": "meshdir", "texture": "texturedir"}
_MODEL_FILES = ("include", "model")


def _elements(xml: Path, base: Path, seen: set) -> list:
    """Every element of ``xml`` and of the MJCF files it includes (relative to ``base``), with the
    file it is in: [(file, element)]."""
    out = []
    for el in ET.parse(xml).getroot().iter():
        out.append((xml, el))
        if el.tag in _MODEL_FILES and el.get("file"):
            inc = Path(os.path.normpath(base / el.get("file")))
            if inc not in seen and inc.is_file():
                seen.add(inc)
                out += _elements(inc, base, seen)
    return out


def referenced_files(xml: str | Path) -> list[tuple[str, Path, str]]:
    """``(where, path, written)`` of each file the MJCF at ``xml`` references (module docstring),
    once each in document order: ``where`` names the element and attribute (``mesh 'hull' file``),
    ``path`` is absolute and normalised without following links (it may lie outside the MJCF's
    folder), ``written`` the path as the MJCF gives it (with its asset folder). Raises OSError /
    ET.ParseError."""
    xml = Path(os.path.abspath(xml))
    base = xml.parent
    elements = _elements(xml, base, {xml})
    dirs: dict[str, str] = {}
    for _, el in elements:
        if el.tag == "compiler":
            for attr in ("meshdir", "texturedir", "assetdir"):
                if el.get(attr) is not None:
                    dirs.setdefault(attr, el.get(attr))
    out: dict[Path, tuple[str, str]] = {}
    for _, el in elements:
        if el.tag in _MODEL_FILES:
            folder = ""
        elif el.tag in _DIR_OF:
            folder = dirs.get(_DIR_OF[el.tag], dirs.get("assetdir", ""))
        else:
            continue
        for attr in _FILE_ATTRIBUTES:
            value = el.get(attr)
            if value:
                name = f" {el.get('name')!r}" if el.get("name") else ""
                written = os.path.join(folder, value)
                out.setdefault(Path(os.path.normpath(base / written)), (f"{el.tag}{name} {attr}", written))
    return [(where, path, written) for path, (where, written) in out.items()]


def folder_files(folder: str | Path, *, outside_ok: bool = False) -> dict[str, Path]:
    """``{path relative to the folder (POSIX): absolute path}`` of every file runs read from the
    vessel folder (module docstring): the two files first, then the MJCF's references. Raises
    ValueError (one line naming the MJCF, the element and the file) for a reference outside the
    folder, or given by its absolute path, which a copy of the folder elsewhere would not have —
    unless ``outside_ok`` (the digest, which covers such a file too: keyed by its absolute path)."""
    folder = Path(os.path.abspath(folder))
    files = {f.format(name=folder.name): folder / f.format(name=folder.name) for f in HULL_FILES}
    xml = files[f"{folder.name}.xml"]
    for where, path, written in referenced_files(xml):
        if outside_ok:
            files.setdefault(path.relative_to(folder).as_posix() if path.is_relative_to(folder) else str(path), path)
            continue
        if os.path.isabs(written):
            raise ValueError(f"{xml}: {where}: {written} is an absolute path (a campaign's workers sail a copy "
                             f"of the folder elsewhere: write it relative to the MJCF's folder)")
        try:
            rel = path.relative_to(folder).as_posix()
        except ValueError:
            raise ValueError(f"{xml}: {where}: {path} lies outside the vessel folder (a campaign's workers get "
                             f"a copy of the folder: keep the hull's files in it)") from None
        files.setdefault(rel, path)
    return files


def read_folder(folder: str | Path) -> dict[str, bytes]:
    """The content of :func:`folder_files` (relative path → bytes), read once. Raises ValueError
    (one line naming the file and the reason)."""
    try:
        files = folder_files(folder)
    except OSError as exc:
        raise ValueError(f"{exc.filename or folder}: cannot be read ({exc.strerror or exc})") from None
    except ET.ParseError as exc:
        raise ValueError(f"{Path(folder) / (Path(folder).name + '.xml')}: not valid XML ({exc})") from None
    out = {}
    for rel, path in files.items():
        try:
            out[rel] = path.read_bytes()
        except OSError as exc:
            raise ValueError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    return out


def content_hashes(name: str, files: dict[str, bytes]) -> dict[str, str]:
    """The SHA-256 of each of a hull's files (``files``: path → content, the folder named ``name``)
    as the campaign digest covers them (module docstring): ``<name>.xml`` canonical without
    comments, ``hydrodynamics.toml`` as parsed, any other file as it is."""
    out = {}
    for rel, data in files.items():
        if rel == f"{name}.xml":
            data = ET.canonicalize(xml_data=data, with_comments=False, strip_text=True).encode()
        elif rel == "hydrodynamics.toml":
            data = json.dumps(tomllib.loads(data.decode("utf-8")), sort_keys=True).encode()
        out[rel] = hashlib.sha256(data).hexdigest()
    return out


def fingerprint(hashes: dict[str, str]) -> str:
    """A hull's short content tag (:data:`FINGERPRINT_CHARS` hex digits) from its
    :func:`content_hashes`."""
    return hashlib.sha256(json.dumps(hashes, sort_keys=True).encode()).hexdigest()[:FINGERPRINT_CHARS]


def is_folder_type(vessel_type: str) -> bool:
    """Whether a resolved vessel ``type`` is a folder (an absolute path), not a built-in name."""
    return os.path.isabs(vessel_type)
