"""Delfim domain: the thesis's Delfim-class catamaran on the single-vessel tasks of the otter domain.

Same tasks, rewards and observations as :mod:`mjasc.suite.otter` (its MJCF additions too), with
the Delfim's hull, hydrodynamics and cruise speed (1.0 m/s). Not tagged ``benchmarking``: the
Otter tasks are the benchmark set, these are extras (``mjasc.suite.EXTRA``).
"""

from dm_control.utils import containers

from mjasc.suite import otter

SUITE = containers.TaggedTasks()
VESSEL_TYPE = "delfim"


def get_model_and_assets():
    """The domain MJCF (shared with the otter domain) and its assets (none)."""
    return otter.get_model_and_assets()


otter.register_tasks(SUITE, VESSEL_TYPE, tags=())
