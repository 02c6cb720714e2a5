"""Test set-up shared by every test module.

MuJoCo and dm_control read MUJOCO_GL once, at import: importing mjasc first picks OSMesa (or says
why not) before any test module imports mujoco.
"""

import os

os.environ.setdefault("MUJOCO_GL", "osmesa")

import mjasc  # noqa: E402,F401
