"""The model a video pane renders: a copy of the run's model with render-only changes.

MuJoCo draws a scene from a model (colours, sizes) and a data (poses). Each pane of a video
(:mod:`mjasc.runs.video`) renders with its own copy of the run's model (``mj_copyModel``), changed
only in what is drawn; the run steps, senses and records with its own model, untouched:

- **Liveries** (:func:`paint_liveries`): each vessel's livery material — its copy of a material
  named in :data:`LIVERY_MATERIALS` (the Otter's yellow pontoons, the Delfim's red stripes, deck
  strips and housing) or one whose name ends in ``_livery`` — takes the vessel's palette colour
  (:func:`mjasc.runs.blueprint.vessel_colour`), the colour the HUD, the legend, the recording and
  the figures give the vessel. Deck, frame and details keep the model's colours. The materials
  are the vessel's own: ``world.build_world`` attaches each vessel's MJCF under its name
  (``alpha/otter_pontoon``).
- **Water** (:func:`widen_water`): the water plane reaches past a framed view (MuJoCo builds a
  plane's drawing from its size: the scene's 1 km plane ended inside fleet_50's view, a light strip).
- **Walls** (:func:`thicken_walls`): a structure's walls (``obstacle_<name>_wall<k>`` boxes,
  0.4 m thick) at least :data:`WALL_MIN_PX` pixels thick in a framed view. A thinner wall is a
  1-pixel line, and the MP4's 4:2:0 chroma (one colour sample per 2 × 2 pixels) mixes its brown
  with the water's blue: it showed blue-grey. Walls keep their centre line (MuJoCo places a
  static geom from the run's data), so a thickened wall also reaches outside the structure's
  outline by half the added thickness (about a pixel).
- **Far plane** (:func:`reach_far`): MuJoCo clips what lies beyond ``zfar × extent`` (1 km in the
  water scene); a camera framed from farther away saw only the sky.

All of it is visual: no collision, sensing or recording reads a render model.
"""

from __future__ import annotations

import copy
import re

import mujoco
import numpy as np

from mjasc.physics.vessel_contract import LIVERY_MATERIALS, is_livery_material
from mjasc.runs.blueprint import vessel_colour

__all__ = ["render_model", "paint_liveries", "widen_water", "thicken_walls", "reach_far", "model_vessels",
           "LIVERY_MATERIALS", "WALL_MIN_PX"]

# LIVERY_MATERIALS (mjasc.physics.vessel_contract): the materials (names as in the vessel's MJCF)
# that carry a vessel's livery; a material whose name ends in ``_livery`` does too (a new vessel
# type opts in by naming it so). A hull without one keeps the model's own colours.
#: A framed view draws a structure's walls at least this many pixels thick (4:2:0 chroma: 2 × 2).
WALL_MIN_PX = 3.0
_WALL = re.compile(r"obstacle_.+_wall\d+")


def render_model(model, vessel_colours=None, centre=None, span_m: float = 0.0, aspect: float = 1.0,
                 metres_per_pixel: float = 0.0, distance_m: float = 0.0):
    """A copy of ``model`` to render one pane with: liveries painted (``vessel_colours``: (name,
    RGB 0–255) per vessel, default :func:`model_vessels`); for a framed view (``span_m`` > 0 [m]
    high around ``centre``, frame ``aspect`` = width / height, ``metres_per_pixel`` at its centre,
    camera ``distance_m`` away) the water widened, the walls thickened and the far plane beyond
    the view. ``model`` itself is never changed."""
    out = copy.copy(model)  # mj_copyModel
    paint_liveries(out, model_vessels(out) if vessel_colours is None else vessel_colours)
    if span_m > 0.0:
        widen_water(out, centre, span_m, aspect)
        thicken_walls(out, WALL_MIN_PX * metres_per_pixel)
        reach_far(out, distance_m + span_m * max(1.0, aspect))
    return out


def model_vessels(model) -> list[tuple[str, tuple[int, int, int]]]:
    """(name, palette colour) of the model's vessels in their order: the bodies ``<name>/hull``
    (``world.build_world`` attaches the vessels in the scenario's order)."""
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or "" for b in range(model.nbody)]
    return [(n[:-len("/hull")], vessel_colour(i)) for i, n in enumerate(n for n in names if n.endswith("/hull"))]


def paint_liveries(model, vessel_colours) -> None:
    """Each vessel's livery materials (``<name>/<material>``, :data:`LIVERY_MATERIALS`) in its colour."""
    colours = {name: np.asarray(rgb[:3], float) / 255.0 for name, rgb in vessel_colours}
    for k in range(model.nmat):
        owner, _, material = (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MATERIAL, k) or "").rpartition("/")
        if owner in colours and is_livery_material(material):
            model.mat_rgba[k, :3] = colours[owner]


def widen_water(model, centre, span_m: float, aspect: float) -> None:
    """The water plane (the geom ``water``) past a view of ``span_m`` [m] around ``centre`` (the
    plane collides with nothing and the range sensor excludes it)."""
    wid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "water")
    if wid < 0:
        return
    reach = float(np.abs(np.asarray(centre, float)[:2]).max() + 2.0 * span_m * max(1.0, aspect))
    if reach > float(model.geom_size[wid][:2].min()):
        model.geom_size[wid, :2] = reach


def thicken_walls(model, thickness_m: float) -> None:
    """Every structure wall at least ``thickness_m`` [m] thick, longer by as much (closed corners)."""
    half = 0.5 * float(thickness_m)
    for g in range(model.ngeom):
        if model.geom_type[g] != mujoco.mjtGeom.mjGEOM_BOX or model.geom_size[g, 1] >= half:
            continue
        if _WALL.fullmatch(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or ""):
            grow = half - model.geom_size[g, 1]
            model.geom_size[g, :2] += grow
            model.geom_rbound[g] = float(np.linalg.norm(model.geom_size[g]))


def reach_far(model, depth_m: float) -> None:
    """MuJoCo's far plane (``vis.map.zfar × stat.extent``) at least ``depth_m`` [m] away."""
    extent = float(model.stat.extent)
    if extent > 0.0 and model.vis.map.zfar * extent < depth_m:
        model.vis.map.zfar = float(depth_m) / extent
