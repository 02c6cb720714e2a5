"""Test set-up shared by every test module.

MuJoCo and dm_control read MUJOCO_GL once, at import: importing mjasc first picks OSMesa (or says
why not) before any test module imports mujoco.
"""

import os

os.environ.setdefault("MUJOCO_GL", "osmesa")
# The CLI's one-line hints that numba compiles kernels (mjasc.core.kernel_cache) depend on what
# other tests have cached by then: off for every test and the commands they start, but where tested.
os.environ.setdefault("MJASC_COMPILE_HINTS", "0")

import mjasc  # noqa: E402,F401
