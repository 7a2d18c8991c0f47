"""A grasp in a bin, near its walls: the planner's spheres reach ~1-2 cm beyond the Panda hand's collision geometry, so
they put the hand into the wall at a grasp the detector found clear; ``PickPlace`` then measures the straight
approach with the links' exact geometry (``PickPlaceConfig.exact_approach_clearance``) and takes it. Judged
independently: the hand's collision primitives sampled on their surfaces at the grasp configuration, and the
analytic distance of those points to the wall box (numpy only)."""

from __future__ import annotations

import numpy as np
import pytest
from test_exact_clearance import _box_distance, _robot_points

import ferrobot
from ferrobot.pipeline import PickPlace, PickPlaceConfig
from ferrobot.pipeline.clutter import BinSpec
from ferrobot.pipeline.scene import CLUTTER_CENTER, CLUTTER_PLACE, TABLE_TOP, ObjectSpec, SceneSpec, place_camera

BIN = BinSpec(center=CLUTTER_CENTER)


def _scene(gap: float) -> SceneSpec:
    """A 4 x 6 x 5 cm box ``gap`` from the bin's -x wall, its 6 cm side along the wall."""
    x = CLUTTER_CENTER[0] - BIN.inner[0] / 2 + gap + 0.02
    box = ObjectSpec("box", "box", (0.04, 0.06, 0.05), [x, CLUTTER_CENTER[1], TABLE_TOP + 0.025, 1, 0, 0, 0])
    return SceneSpec(
        seed=0,
        objects=[box],
        target="box",
        place_xy=CLUTTER_PLACE,
        bin=BIN,
        camera_target=(CLUTTER_CENTER[0], CLUTTER_CENTER[1], TABLE_TOP),
    )


def _wall_distances(model, q_full: np.ndarray, base: np.ndarray) -> dict[str, float]:
    """Smallest distance (sampled surfaces of every link's primitives, robot on ``base``) to each wall box."""
    pts = np.vstack(list(_robot_points(model, q_full).values()))
    pts = pts @ base[:3, :3].T + base[:3, 3]
    return {
        name: float(_box_distance(pts, pose[:3], np.asarray(size) / 2).min())
        for name, size, pose in BIN.walls(TABLE_TOP)
    }


@pytest.mark.parametrize("gap", [0.002, 0.004, 0.008])
def test_grasp_beside_a_wall_is_taken_with_the_exact_approach(gap):
    spec = _scene(gap)
    pp = PickPlace(PickPlaceConfig(preshape_margin=0.01))
    place_camera(spec, pp.model, pp.gripper)
    result = pp.run(spec, record_frames=False)
    ep = result.episode
    select = next(s for s in result.stages if s.name == "select")
    assert select.ok, select.reason
    walls = [n for n in select.detail["exact_approach"] if n.startswith("bin_wall")]
    assert walls, select.detail
    # At the grasp configuration the robot is clear of the walls the spheres touch, by the real geometry.
    q = np.asarray(pp.planner.locked_positions, dtype=float).copy()
    names = list(pp.planner.dof_names)
    for k, n in enumerate(pp.arm):
        q[names.index(n)] = ep.q_grasp[k]
    dist = _wall_distances(pp.model, q, np.asarray(ep.base, dtype=float))
    assert all(dist[n] > 0.0 for n in walls), dist
    assert result.success, result.reason


def test_without_the_exact_approach_the_spheres_refuse_it():
    spec = _scene(0.004)
    pp = PickPlace(PickPlaceConfig(preshape_margin=0.01, exact_approach_clearance=None))
    place_camera(spec, pp.model, pp.gripper)
    result = pp.run(spec, record_frames=False)
    assert not result.success and result.failed_stage == "select", result.reason


def test_exact_approach_clearance_range():
    with pytest.raises(ferrobot.errors.InvalidArgumentError, match="exact_approach_clearance"):
        PickPlace(PickPlaceConfig(exact_approach_clearance=0.5))
