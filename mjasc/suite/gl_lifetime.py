"""The lifetime of a suite physics's GL contexts: freed at interpreter exit when the environment was
never closed, and freed first when the garbage collector frees the physics (dm_control's render
thread must still run while a context is freed)."""

from __future__ import annotations

import threading
import weakref

__all__ = ["track_rendering"]

_RENDERING = weakref.WeakSet()  # physics instances that hold GL contexts
_EXIT_HOOK_REGISTERED = False


def _free_rendering_at_exit() -> None:
    """Free the GL contexts of physics that were never closed, while dm_control's render thread
    still runs (otherwise it prints "cannot schedule new futures after shutdown" at exit)."""
    for physics in list(_RENDERING):
        with physics._contexts_lock:
            if physics._contexts:
                physics._free_rendering_contexts()


def _free_contexts(contexts) -> None:
    """Free a garbage-collected physics's GL contexts while their render thread still runs.

    A VesselPhysics is in reference cycles (its World and Simulation refer back to it), so the
    cyclic garbage collector, not reference counting, frees an environment that was dropped
    without ``close()``. When its contexts were part of that garbage, the collector first ran the
    weakref callback of their render thread pool, which stops its worker, and then their
    ``__del__``, which waited forever for that worker to free the GL context: a dropped
    environment that had rendered hung the next ``gc.collect()``. Held by a ``weakref.finalize``
    of the physics, the contexts stay reachable (so does their thread) and are freed here, from
    the finalizer, before anything else of the physics is torn down. Freeing twice is harmless
    (``close()`` or the exit hook may have freed them already).
    """
    contexts.mujoco.free()
    contexts.gl.free()


def _register_exit_hook() -> None:
    # threading's exit hooks run in reverse order of registration, before ``atexit``; registered
    # after dm_control's executor module is imported, this one runs before its thread pools stop.
    global _EXIT_HOOK_REGISTERED
    register = getattr(threading, "_register_atexit", None)
    if not _EXIT_HOOK_REGISTERED and register is not None:
        register(_free_rendering_at_exit)
        _EXIT_HOOK_REGISTERED = True


def track_rendering(physics) -> None:
    """Free ``physics``'s rendering contexts (just made) at interpreter exit if it is never closed,
    and from a finalizer when the garbage collector frees it (:func:`_free_contexts`)."""
    _RENDERING.add(physics)
    _register_exit_hook()
    weakref.finalize(physics, _free_contexts, physics._contexts).atexit = False
