"""What the ``mjasc`` commands share: the bundled-name hint, the output folder (made and proven
writable before anything runs) and the suite's task list for messages."""

from __future__ import annotations

from pathlib import Path

NAMED_HELP = "'mjasc list' shows the bundled names"


def not_found_hint(ref: str, kind: str) -> str:
    """A hint when ``ref`` is neither a file here nor a bundled name, else ''."""
    from mjasc.core.resources import resolve_bundled

    if resolve_bundled(ref, kind) == Path(ref) and not Path(ref).exists():
        hint = _did_you_mean(ref, kind)
        return f" (neither a file relative to {Path.cwd()} nor a bundled {kind}: {NAMED_HELP}{hint})"
    return ""


def _did_you_mean(ref: str, kind: str) -> str:
    """'; did you mean 'imazu/imazu_05'?' for a bundled name given without its folder (``imazu_05``)
    or misspelt (``thesis_6_2_dok``), else ''."""
    import difflib

    from mjasc.core.resources import bundled_campaigns, bundled_scenarios

    names = [n.removeprefix("campaigns/") for n in (bundled_scenarios() if kind == "scenario" else bundled_campaigns())]
    stem = Path(ref).name.removesuffix(".toml")
    close = [n for n in names if n.rsplit("/", 1)[-1] == stem] or difflib.get_close_matches(stem, names, 1, 0.8)
    return f"; did you mean {close[0]!r}?" if close else ""


def out_dir(given: str | None, default: Path | None) -> Path:
    """The output folder (``--out`` or the default), made and proven writable before anything runs
    (:func:`mjasc.runs.outputs.check_out_dir`; raises OutputError, which :func:`mjasc.cli.main` reports)."""
    from mjasc.runs.outputs import check_out_dir

    return check_out_dir(given if given is not None else default, "--out" if given is not None else "output folder")


def suite_tasks(by_domain) -> str:
    return "; ".join(f"{d}: {', '.join(t)}" for d, t in by_domain.items())
