"""mjasc: cooperative guidance and collision avoidance for autonomous surface craft in MuJoCo.

Importing mjasc chooses the offscreen OpenGL backend before MuJoCo or dm_control is imported
(both read ``MUJOCO_GL`` once, at import): OSMesa (software, Debian's libosmesa6) unless the user
set ``MUJOCO_GL`` already; EGL as a stated fallback when libOSMesa is missing. Before numpy is
imported, it also pins numpy's and OpenBLAS's loops below AVX-512, so that a seed gives the same
bits on every x86-64 CPU with AVX2 (:mod:`mjasc.core.portable_math`; ``MJASC_NATIVE_MATH=1``: not).

The top-level API (stable; each name is loaded on first use, so ``import mjasc`` stays cheap and
imports neither MuJoCo nor numpy)::

    import mjasc

    scenario = mjasc.load_scenario("demo")          # a bundled name or a file path
    result = mjasc.run_scenario(scenario.with_overrides(duration_s=10.0), "runs/demo")
    campaign = mjasc.load_campaign("demo_monte_carlo")
    result = mjasc.run_campaign(campaign.with_overrides(runs=4), "runs/mc", workers=0)
    env = mjasc.suite.load("otter", "path_following")

* ``load_scenario(path_or_name)`` — :func:`mjasc.runs.scenario.load_scenario`: a scenario TOML file
  (relative to the current folder) or a bundled scenario's name (``mjasc list`` shows them).
* ``run_scenario(scenario, out_dir, progress=None)`` — :func:`mjasc.runs.runner.run_scenario`.
* ``load_campaign(path_or_name)`` — :func:`mjasc.campaigns.spec.load_campaign_spec` (a
  :class:`~mjasc.campaigns.spec.CampaignSpec`: encounter families, Imazu cases, perturbations).
* ``run_campaign(campaign, out_dir, scheduler=None, workers=None, …)`` —
  :func:`mjasc.campaigns.engine.run_campaign`.
* ``bundled_scenarios()``, ``bundled_campaigns()`` — name → file of the shipped scenarios and
  campaigns (:mod:`mjasc.core.resources`).
* ``suite`` — the dm_control suite, :mod:`mjasc.suite` (``mjasc.suite.load(domain, task)``).

In the ``mjasc`` program (the console script, ``python -m mjasc``) importing mjasc first hands
Ctrl-C and SIGTERM to one line and status 130 (:mod:`mjasc.runs.early_interrupts`), before anything
else is imported.
"""

# (first: the program's imports below are interruptible too; the module imports only os, signal and sys)
from mjasc.runs.early_interrupts import install_for_the_program as _handle_early_interrupts

_handle_early_interrupts()

import ctypes.util  # noqa: E402
import importlib  # noqa: E402
import os  # noqa: E402
import warnings  # noqa: E402

if "MUJOCO_GL" not in os.environ:
    if ctypes.util.find_library("OSMesa"):
        os.environ["MUJOCO_GL"] = "osmesa"
    else:
        os.environ["MUJOCO_GL"] = "egl"
        warnings.warn("libOSMesa not found (Debian package libosmesa6): offscreen rendering falls back to EGL",
                      stacklevel=2)

# numpy's and OpenBLAS's loops pinned below AVX-512 before numpy loads: the same bits on every x86-64
# CPU with AVX2 (mjasc.core.portable_math).
from mjasc.core.portable_math import pin as _pin_math  # noqa: E402  (imports neither numpy nor MuJoCo)

_pin_math()

__version__ = "0.1.0"

# Public name -> (module, attribute); attribute None: the module itself. Resolved on first access
# (module __getattr__, PEP 562), after MUJOCO_GL is set above.
_LAZY = {
    "load_scenario": ("mjasc.runs.scenario", "load_scenario"),
    "run_scenario": ("mjasc.runs.runner", "run_scenario"),
    "load_campaign": ("mjasc.campaigns.spec", "load_campaign_spec"),
    "run_campaign": ("mjasc.campaigns.engine", "run_campaign"),
    "bundled_scenarios": ("mjasc.core.resources", "bundled_scenarios"),
    "bundled_campaigns": ("mjasc.core.resources", "bundled_campaigns"),
    "suite": ("mjasc.suite", None),
}

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str):
    try:
        module_name, attribute = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'mjasc' has no attribute {name!r}") from None
    module = importlib.import_module(module_name)
    value = module if attribute is None else getattr(module, attribute)
    globals()[name] = value  # later look-ups skip __getattr__
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
