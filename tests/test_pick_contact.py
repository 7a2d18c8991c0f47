"""Picking an object that touches a neighbour (issue 18): the lift's first part allows the contacts the held
object has when the gripper closes (MoveIt's post-grasp retreat), the rest is planned with nothing ignored.
Judged from the simulator: the target ends at the place location and the neighbour was not dragged."""

from __future__ import annotations

import numpy as np
import pytest

from ferrobot.errors import InvalidArgumentError
from ferrobot.pipeline import TABLE_TOP, PickPlace, PickPlaceConfig
from ferrobot.pipeline.scene import ObjectSpec, SceneSpec


def _touching_pair() -> SceneSpec:
    # A box standing against a lower one (no gap): lifted straight up, the target slides along the
    # neighbour's face for its first 6 cm. The planner sees the held box in the neighbour when the gripper
    # closes ("start in collision" before the straight lift existed).
    target = ObjectSpec("target", "box", (0.05, 0.07, 0.09), [0.5, 0.0, TABLE_TOP + 0.045, 1, 0, 0, 0], 0.15, 0.9)
    neighbour = ObjectSpec(
        "neighbour", "box", (0.06, 0.06, 0.06), [0.5, 0.065, TABLE_TOP + 0.03, 1, 0, 0, 0], 0.15, 0.9
    )
    return SceneSpec(seed=0, objects=[target, neighbour], target="target", place_xy=(0.45, -0.25))


def test_pick_from_contact_leaves_the_neighbour():
    spec = _touching_pair()
    pp = PickPlace()
    result = pp.run(spec)
    ep = result.episode
    lift = next(s for s in result.stages if s.name == "lift")
    assert lift.ok, (result.failed_stage, result.reason)
    assert "neighbour" in lift.detail["allowed_contacts"]
    assert 0 < lift.detail["escape_distance_mm"] < 1e3 * pp.config.lift_height
    assert result.success, (result.failed_stage, result.reason)
    # Simulator state: the target rests at the place location, the neighbour where it stood.
    pose = ep.world.get_object_pose("target")
    assert np.hypot(*(pose[:2, 3] - spec.place_xy)) < 0.03
    moved = np.linalg.norm(ep.world.get_object_pose("neighbour")[:3, 3] - np.array(spec.objects[1].pose[:3]))
    assert moved < 0.005, f"the neighbour moved {1e3 * moved:.1f} mm"


@pytest.mark.parametrize("field,value", [("escape_step", 0.0), ("escape_step", 0.2), ("escape_clearance", -0.01)])
def test_escape_settings_are_checked(field, value):
    with pytest.raises(InvalidArgumentError, match=f"config.{field}"):
        PickPlace(PickPlaceConfig(**{field: value}))
