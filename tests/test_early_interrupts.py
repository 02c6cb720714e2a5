"""Ctrl-C and SIGTERM in the ``mjasc`` program's first moments (mjasc/runs/early_interrupts.py): from
the package's first statement on, through the console script and ``python -m mjasc``, an interrupt
is the program's one line, ``mjasc: interrupted``, and status 130 — never Python's traceback, nor
status 143 from SIGTERM's default."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mjasc.runs.early_interrupts import _dash_m_module

ROOT = Path(__file__).resolve().parent.parent

#: The console script as the installer writes it (pyproject's ``mjasc = "mjasc.cli:command_line"``).
_CONSOLE_SCRIPT = """import sys
from mjasc.cli import command_line
if __name__ == '__main__':
    sys.argv[0] = sys.argv[0].removesuffix('.exe')
    sys.exit(command_line())
"""

#: A sitecustomize that sends the process a signal as it starts importing a given module: an
#: interrupt landing exactly there, whatever the machine's speed.
_SIGNAL_ON_IMPORT = """import os, signal, sys

class _SignalOnImport:
    @staticmethod
    def find_spec(name, path=None, target=None):
        if name == os.environ["TEST_IMPORT"]:
            sys.meta_path.remove(_SignalOnImport)
            os.kill(os.getpid(), signal.Signals[os.environ["TEST_SIGNAL"]])
        return None

sys.meta_path.insert(0, _SignalOnImport)
"""


def _program(tmp_path, entry: str) -> list[str]:
    if entry == "python -m mjasc":
        return [sys.executable, "-m", "mjasc", "list"]
    script = tmp_path / "mjasc"  # (the script's own name: how the program knows it is the program)
    script.write_text(_CONSOLE_SCRIPT)
    return [sys.executable, str(script), "list"]


def _env(**extra) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("MJASC_TRACEBACK", "PYTHONPATH")}
    return {**env, "MJASC_COMPILE_HINTS": "0", **extra}


@pytest.mark.parametrize("entry", ["python -m mjasc", "console script"])
@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
@pytest.mark.parametrize("module", ["ctypes", "mjasc.core.portable_math", "mjasc.cli.parser", "numpy"])
def test_an_interrupt_while_the_program_imports_is_one_line_and_130(tmp_path, entry, signame, module):
    """The signal lands as the program starts importing ``module``: the package's own first import
    (``ctypes``, for the OpenGL back end), its math set-up, the command line's modules, and numpy
    (the command's set-up: the command's handler by then)."""
    hook = tmp_path / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(_SIGNAL_ON_IMPORT)
    env = _env(PYTHONPATH=os.pathsep.join([str(hook), str(ROOT)]), TEST_IMPORT=module, TEST_SIGNAL=signame)
    proc = subprocess.run(_program(tmp_path, entry), env=env, cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    assert (proc.returncode, proc.stderr, proc.stdout) == (130, "mjasc: interrupted\n", "")


def _catches(pid: int, signum: int) -> bool | None:
    """Whether process ``pid`` has a handler for ``signum`` (Linux's /proc; None: it has ended)."""
    try:
        with open(f"/proc/{pid}/status") as status:
            caught = next(int(line.split()[1], 16) for line in status if line.startswith("SigCgt:"))
    except (FileNotFoundError, ProcessLookupError, StopIteration):
        return None
    return bool(caught >> (signum - 1) & 1)


@pytest.mark.skipif(not os.path.exists(f"/proc/{os.getpid()}/status"), reason="needs Linux's /proc")
@pytest.mark.parametrize("entry", ["python -m mjasc", "console script"])
def test_a_signal_at_early_delays_is_one_line_and_130(tmp_path, entry):
    """A signal at several delays after the program can first handle one (seen from outside: its
    SIGTERM caught): 0–150 ms, while it imports and sets the command up."""
    env = _env(PYTHONPATH=str(ROOT))
    for k, delay_s in enumerate((0.0, 0.005, 0.02, 0.06, 0.15)):
        for signum in (signal.SIGINT, signal.SIGTERM):
            proc = subprocess.Popen(_program(tmp_path, entry), env=env, cwd=tmp_path, stdout=subprocess.PIPE,
                                    stderr=subprocess.PIPE, text=True)
            deadline = time.monotonic() + 60.0
            while not _catches(proc.pid, signal.SIGTERM):
                assert proc.poll() is None and time.monotonic() < deadline, "the program never handled SIGTERM"
            time.sleep(delay_s)
            proc.send_signal(signum)
            out, err = proc.communicate(timeout=300)
            assert (proc.returncode, err, out) == (130, "mjasc: interrupted\n", ""), (delay_s, signum.name)


@pytest.mark.parametrize("argv, module", [
    (["python", "-m", "mjasc", "list"], "mjasc"),
    (["python", "-mmjasc"], "mjasc"),
    (["python", "-X", "importtime", "-Im", "mjasc"], "mjasc"),
    (["python", "-Wignore", "-m", "mjasc.core.math_fingerprint"], "mjasc.core.math_fingerprint"),
    (["python", "--check-hash-based-pycs", "never", "-m", "mjasc"], "mjasc"),
    (["python", "-c", "import mjasc", "-m", "mjasc"], None),
    (["python", "script.py", "-m", "mjasc"], None),
    (["python"], None),
])
def test_the_module_python_dash_m_runs_is_read_from_the_interpreter_s_command_line(argv, module):
    assert _dash_m_module(argv) == module
