"""Input files: a path a user gave and the TOML file behind it, every problem one line naming the file.

Scenario and campaign files arrive from command lines and other files, so anything can come:
a NUL character or a 5,000-character name (which the OS answers with ValueError or OSError
ENAMETOOLONG), a folder, ``/proc/self/mem``, binary bytes, invalid UTF-8, TOML nested too deeply.
:func:`load_toml` turns each into the caller's own error type (``ScenarioError``,
``CampaignError``, by default :class:`~mjasc.core.config_tables.ConfigError`), one line naming
the file and the reason; :func:`path_problem` says why a path cannot name a file before the OS is
asked; :func:`show_path` and :func:`one_line` keep what a message shows on one line.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

__all__ = ["load_toml", "path_problem", "show_path", "one_line", "MAX_TOML_BYTES", "MAX_PATH_CHARS"]


def load_toml(path: str | Path, error: type[ValueError] | None = None, what: str = "TOML") -> dict:
    """Read the TOML file ``path`` into its top-level table. Raises ``error`` (a ValueError
    subclass; default :class:`~mjasc.core.config_tables.ConfigError`), one line naming the file: ``"<path>: no such <what> file"``, ``"<path>: not a
    usable file name (<reason>)"`` (a NUL, an over-long name), ``"<path>: cannot read: <reason>"``,
    ``"<path>: not UTF-8 text (byte 0x.. at offset n)"`` or ``"<path>: not valid TOML: <reason>"``."""
    if error is None:
        from mjasc.core.config_tables import ConfigError as error
    shown = show_path(path)
    reason = path_problem(path)
    if reason:
        raise error(f"{shown}: not a usable file name ({reason})")
    if not str(path):
        raise error(f"'': an empty path, not a {what} file")
    path = Path(path)
    try:
        if path.is_dir():
            raise error(f"{shown}: a folder, not a {what} file")
        if not path.is_file():
            raise error(f"{shown}: no such {what} file")
        with open(path, "rb") as f:
            raw = f.read(MAX_TOML_BYTES + 1)
    except OSError as exc:
        raise error(f"{shown}: cannot read: {exc.strerror or exc}") from None
    if len(raw) > MAX_TOML_BYTES:
        raise error(f"{shown}: larger than {MAX_TOML_BYTES} bytes, not a {what} file")
    if raw.startswith(b"\xef\xbb\xbf"):  # (a UTF-8 byte-order mark, as some editors write: not TOML's, skipped)
        raw = raw[3:]
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{shown}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{shown}: not valid TOML: {one_line(str(exc))}") from None
    except RecursionError:
        raise error(f"{shown}: not valid TOML: nested too deeply") from None


MAX_TOML_BYTES = 64 * 1024 * 1024
"""Largest config file read [bytes] (a scenario of thousands of vessels is well under a megabyte)."""

MAX_PATH_CHARS = 4096
"""Longest file path accepted (Linux PATH_MAX); one name (between slashes) at most 255 bytes."""


def path_problem(path: Any) -> str:
    """Why ``path`` cannot name a file ("" if it can): a NUL character, an unencodable character,
    more than :data:`MAX_PATH_CHARS` characters or a name (between slashes) over 255 bytes. Checked
    before the path reaches the OS, so that the answer is a sentence rather than an OSError."""
    text = str(path)
    if "\x00" in text:
        return "contains a NUL character"
    try:
        encoded = text.encode("utf-8")
    except UnicodeEncodeError:
        return "contains a character that is not valid UTF-8"
    if len(encoded) > MAX_PATH_CHARS:
        return f"longer than {MAX_PATH_CHARS} bytes"
    if any(len(part) > 255 for part in encoded.split(b"/")):
        return "a name in it is longer than 255 bytes"
    return ""


def show_path(path: Any) -> str:
    """A path as an error message shows it: on one line, NUL and control characters escaped,
    cut to 120 characters."""
    text = one_line(str(path).encode("utf-8", "backslashreplace").decode("utf-8"))
    return text if len(text) <= 120 else text[:100] + "..." + text[-17:]


def one_line(text: str) -> str:
    """``text`` on one line: newlines and control characters shown escaped (``\\n``, ``\\x00``)."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
