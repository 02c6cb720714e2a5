"""Which hulls a campaign's own vessels sailed, per family: recorded in the store, named by the report.

The driver records, with the campaign in its store (:mod:`mjasc.campaigns.store`, the campaigns
table's ``hulls``), each family's hulls as its runs' scenarios name them (a family's runs share
their vessels' types: the family's first run is read): per distinct type, a record
``{"hull", "folder", "fingerprint", "vessels"}`` — a built-in hull by its name (``folder`` and
``fingerprint`` None), a vessel folder by its name, the absolute path the driver read it from and
the short fingerprint of its content (:func:`mjasc.physics.hull_files.fingerprint`: two folders
named ``my_hull`` with different hulls differ, an edited comment does not), and the names of the
vessels that sailed it. A report made anywhere from the store alone names them; a store written
before the records existed reports its hulls as unknown.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from mjasc.campaigns.hull_shipping import run_vessel_types
from mjasc.physics.hull_files import is_folder_type

__all__ = ["run_hulls", "family_hulls", "hull_label", "hulls_text", "hull_tag", "family_ticks",
           "family_title", "hull_table", "UNKNOWN"]

#: What the report says of a family whose hulls the store does not record.
UNKNOWN = "unknown (the store was written before mjasc recorded the hulls)"


def _fingerprint(folder: str) -> str | None:
    from mjasc.physics.vessels import vessel_fingerprint

    try:
        return vessel_fingerprint(folder)
    except (OSError, ValueError, ET.ParseError):  # (gone since the campaign was read: not known)
        return None


def run_hulls(scenario_toml: str, packs: dict | None = None) -> list[dict]:
    """The hull records (module docstring) of a run's scenario text, in vessel order; a folder's
    fingerprint from ``packs`` (``{path: {"fingerprint": …}}``, as
    :func:`mjasc.campaigns.hull_shipping.pack_hulls` makes them) when it has the folder, else read
    now (and added to ``packs``, when given)."""
    records: dict[str, dict] = {}
    for _, name, vtype in run_vessel_types(scenario_toml):
        rec = records.get(vtype)
        if rec is None:
            folder = is_folder_type(vtype)
            if folder and packs is not None and vtype not in packs:
                packs[vtype] = {"fingerprint": _fingerprint(vtype)}
            fp = (packs[vtype]["fingerprint"] if packs is not None else _fingerprint(vtype)) if folder else None
            rec = records[vtype] = {"hull": Path(vtype).name if folder else vtype, "folder": vtype if folder else None,
                                    "fingerprint": fp, "vessels": []}
        rec["vessels"].append(name)
    return list(records.values())


def family_hulls(campaign, packs: dict | None = None) -> dict[str, list[dict]]:
    """``{family: hull records}`` of each family with runs in ``campaign`` (a CampaignSpec; its
    first run read; each folder's fingerprint read once)."""
    packs = dict(packs or {})
    out: dict[str, list[dict]] = {}
    labels = getattr(campaign, "method_labels", ("",))
    first = 0
    for fam in campaign.families:
        if first >= campaign.runs_per_method:  # (cut short by --runs: the family has no runs)
            break
        run = campaign.run(first, labels[0]) if labels[0] else campaign.run(first)
        out[fam.name] = run_hulls(run.scenario_toml, packs)
        first += fam.runs
    return out


def hull_label(rec: dict) -> str:
    """``otter (built in)``; ``my_hull (folder /path/my_hull, fingerprint 3f2a9c1b7d4e)``."""
    if not rec.get("folder"):
        return f"{rec['hull']} (built in)"
    return f"{rec['hull']} (folder {rec['folder']}, fingerprint {rec.get('fingerprint') or 'unknown'})"


def hulls_text(records: list[dict] | None) -> str:
    """A family's hulls in words, each with the vessels that sailed it; :data:`UNKNOWN` for None."""
    if records is None:
        return UNKNOWN
    return "; ".join(f"{hull_label(r)}: {', '.join(r['vessels'])}" for r in records) or "—"


def hull_tag(records: list[dict] | None) -> str:
    """A family's hulls in a few characters (figure labels): ``otter``, ``my_hull·3f2a9c``, ``?``."""
    if records is None:
        return "?"
    return " + ".join(f"{r['hull']}·{(r.get('fingerprint') or '?')[:6]}" if r.get("folder") else r["hull"]
                      for r in records)


def family_ticks(hulls: dict | None, families: list[str]) -> list[str]:
    """Figure labels of ``families``: each family's name, with its :func:`hull_tag` on a second line
    when any family sails a vessel folder (a campaign of built-in hulls keeps its plain labels)."""
    hulls = hulls or {}
    if not any(r.get("folder") for recs in hulls.values() if recs for r in recs):
        return list(families)
    return [f"{f}\n{hull_tag(hulls.get(f))}" for f in families]


def family_title(hulls: dict | None, family: str) -> str:
    """A figure title's family: ``head_on (my_hull·3f2a9c)`` as :func:`family_ticks` labels it, on one line."""
    tick = family_ticks(hulls, [family])[0]
    return tick.replace("\n", " (") + ")" if tick != family else family


def hull_table(hulls: dict | None, families: list[str]) -> list[str]:
    """The report's Markdown lines naming each family's hulls (``hulls``: the stored records)."""
    lines = ["Hulls the own vessels sailed (a folder: its name, where the driver read it and a fingerprint of "
             "its content):", "", "| family | hull: vessels |", "|---|---|"]
    return lines + [f"| {f} | {hulls_text((hulls or {}).get(f))} |" for f in families] + [""]
