"""A world built again from the same values is copied from the process's compiled model
(:func:`mjasc.physics.world.build_world`): the same model and data bit for bit, the same index
fields, and the same MJCF tree when it is read; a run on it gives the same summary."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import mjasc
from mjasc.physics import world as world_module
from mjasc.physics.vessels import load_vessel_type
from mjasc.physics.world import build_world

SCENES = ("demo", "thesis_6_2_dock", "thesis_6_4_bottleneck", "velocity_obstacle_crossing", "target_tracking_traffic")


def _build(sc):
    vessels = [(v.name, load_vessel_type(v.type)) for v in sc.vessels]
    return build_world(vessels, sc.static_obstacles, sc.moving_obstacles, timestep_s=1.0 / sc.rates.physics_hz)


def _data_arrays(world) -> dict:
    d = world.data
    out = {}
    for name in dir(d):
        if name.startswith("_"):
            continue
        try:
            v = getattr(d, name)
        except Exception:  # noqa: BLE001
            continue
        if isinstance(v, np.ndarray):
            out[name] = v.copy()
    return out


def _fields(world) -> dict:
    return {k: (lambda v: v.copy() if isinstance(v, (np.ndarray, list)) else v)(getattr(world, k)) for k in ("qpos_adr", "dof_adr", "act_adr", "ctrl_adr", "hull_body_id", "mocap_id",
                                            "propeller_lateral_m", "geom_owner", "vessel_names")}


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
    return a == b


@pytest.mark.parametrize("name", SCENES)
def test_a_world_copied_from_the_cache_is_the_compiled_world_bit_for_bit(name):
    sc = mjasc.load_scenario(name)
    world_module._MODELS.clear()
    fresh = _build(sc)
    assert len(world_module._MODELS) == 1
    fresh_model, fresh_data, fresh_fields = fresh.physics.model.to_bytes(), _data_arrays(fresh), _fields(fresh)
    fresh_xml = fresh.mjcf_model.to_xml_string()
    fresh.physics.model.ptr.geom_rgba[:] = 0.5  # a world's own model: changing it leaves the cache alone
    fresh.qpos_adr[:] = -1
    again = _build(sc)
    assert len(world_module._MODELS) == 1  # a hit
    assert "_mjcf_model" in again.__dict__ and not hasattr(again.__dict__["_mjcf_model"], "to_xml_string")
    assert again.physics.model.to_bytes() == fresh_model
    data = _data_arrays(again)
    assert data.keys() == fresh_data.keys() and all(_same(data[k], fresh_data[k]) for k in data)
    fields = _fields(again)
    assert all(_same(fields[k], fresh_fields[k]) for k in fields)
    assert again.mjcf_model.to_xml_string() == fresh_xml  # composed at its first read
    assert again.mjcf_model is again.mjcf_model


def test_other_values_build_another_model_and_the_cache_stays_small():
    sc = mjasc.load_scenario("target_tracking_traffic")
    world_module._MODELS.clear()
    a = _build(sc)
    moved = [replace(o, position_m=np.asarray(o.position_m) + 1.0) for o in sc.moving_obstacles]
    b = _build(replace(sc, moving_obstacles=moved))
    assert len(world_module._MODELS) == 2 and a.physics.model.to_bytes() != b.physics.model.to_bytes()
    for k in range(world_module.MODEL_CACHE_SIZE + 2):
        _build(replace(sc, rates=replace(sc.rates, physics_hz=50.0 + k)))
    assert len(world_module._MODELS) == world_module.MODEL_CACHE_SIZE


def test_a_run_on_a_copied_world_gives_the_same_summary():
    from mjasc.campaigns.engine import without_timing
    from mjasc.runs.runner import Runner

    sc = mjasc.load_scenario("thesis_6_4_crossing").with_overrides(duration_s=8.0)
    sc = replace(sc, outputs=replace(sc.outputs, recording=False, video=False))
    world_module._MODELS.clear()
    first = Runner(sc, None, progress=False)
    s1 = first.run().summary
    second = Runner(sc, None, progress=False)
    assert isinstance(second.world.__dict__["_mjcf_model"], world_module._Deferred)
    assert without_timing(second.run().summary) == without_timing(s1)
