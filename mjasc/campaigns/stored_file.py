"""What a campaign's report reads from the campaign file kept in its store (the parsed file as JSON:
``CampaignStore.file_text``): the compared methods' labels in the file's order, which vessels'
tables they set, and the tracking score's GOSPA settings. Each falls back to the defaults when the
file does not say (an older store, a campaign without methods)."""

from __future__ import annotations

import json

from mjasc.campaigns.campaign_tables import CampaignEvaluation
from mjasc.campaigns.methods import COMPARED_STAGES, STAGE

__all__ = ["file_gospa", "file_compared_tables", "file_methods"]


def _file(text: str) -> dict:
    """The stored file as a dict ({} when it is not one)."""
    try:
        data = json.loads(text)
    except (TypeError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def file_gospa(text: str) -> dict:
    """The tracking score's GOSPA cut-off [m] and order, from the stored file's ``[evaluation]``
    (the defaults when it does not set them)."""
    d = CampaignEvaluation()
    ev = _file(text).get("evaluation") or {}
    ev = ev if isinstance(ev, dict) else {}
    return {"cutoff_m": float(ev.get("gospa_cutoff_m", d.gospa_cutoff_m)),
            "order": float(ev.get("gospa_order", d.gospa_order))}


def file_compared_tables(text: str) -> str:
    """The vessels' tables the compared methods set (``avoidance``, ``tracking``, ``comms``: the
    stored file's ``compare_stage``)."""
    stage = _file(text).get("compare_stage", STAGE)
    return COMPARED_STAGES.get(stage, STAGE) if isinstance(stage, str) else STAGE


def file_methods(text: str) -> list[str]:
    """The method labels in the campaign file's order (from the stored file), or []."""
    entries = _file(text).get("methods") or []
    out = []
    for e in entries if isinstance(entries, list) else []:
        label = e if isinstance(e, str) else (e.get("label", e.get("name")) if isinstance(e, dict) else None)
        if isinstance(label, str):
            out.append(label)
    return out
