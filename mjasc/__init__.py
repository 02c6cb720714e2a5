"""mjasc: cooperative guidance and collision avoidance for autonomous surface craft in MuJoCo.

Importing mjasc chooses the offscreen OpenGL backend before MuJoCo or dm_control is imported
(both read ``MUJOCO_GL`` once, at import): OSMesa (software, Debian's libosmesa6) unless the user
set ``MUJOCO_GL`` already; EGL as a stated fallback when libOSMesa is missing.
"""

import ctypes.util
import os
import warnings

if "MUJOCO_GL" not in os.environ:
    if ctypes.util.find_library("OSMesa"):
        os.environ["MUJOCO_GL"] = "osmesa"
    else:
        os.environ["MUJOCO_GL"] = "egl"
        warnings.warn("libOSMesa not found (Debian package libosmesa6): offscreen rendering falls back to EGL",
                      stacklevel=2)

__version__ = "0.1.0"
