"""The retreat after a release backs straight out until the open fingers are past the placed object's top.

Reference (hand derivation from the Panda URDF's numbers, not the pipeline's geometry code): each finger joint
sits 58.4 mm along the hand's z axis (the approach) and the finger's collision box reaches 54 mm further
(centre 27 mm, height 54 mm), so the fingertips are 112.4 mm from the hand link's origin along the approach.
The placed object of random scene 11 is an upright cylinder (106 mm tall) grasped from above: its top is its
centre plus half its height along its own axis, plus its radius times the axis' tilt.
"""

from __future__ import annotations

import math

import numpy as np

from ferrobot.pipeline import PickPlace, PickPlaceConfig, random_scene

PANDA_TIP = 0.0584 + 0.054  # m, hand origin to fingertip along the approach (panda_finger_joint + finger box)


def _tip_and_top(pp: PickPlace) -> tuple[float, float]:
    """(lowest fingertip height, placed object's top height) in the world, m, from the simulated state."""
    ep = pp.episode
    hand = ep.robot.get_link_pose("panda_hand")
    tip = hand[:3, 3] + PANDA_TIP * hand[:3, 2]
    # The finger box's bottom face is 21.5 mm by 27 mm wide: its corners are up to 17.4 mm from its centre.
    tilt = math.sqrt(max(0.0, 1.0 - hand[2, 2] ** 2))
    tip_z = tip[2] - 0.0174 * tilt
    spec = ep.spec.object(ep.spec.target)
    assert spec.kind == "cylinder"
    pose = ep.world.get_object_pose(ep.spec.target)
    up = abs(pose[2, 2])
    top = pose[2, 3] + 0.5 * spec.size[1] * up + spec.size[0] * math.sqrt(max(0.0, 1.0 - up**2))
    return float(tip_z), float(top)


def test_retreat_backs_out_until_the_fingertips_are_above_a_tall_placed_object():
    pp = PickPlace(PickPlaceConfig())
    seen = []
    escape = pp._escape

    def spy(stage, *args, **kwargs):
        before = _tip_and_top(pp) if stage == "retreat" else None
        out = escape(stage, *args, **kwargs)
        if stage == "retreat":
            seen.append((before, _tip_and_top(pp), out))
        return out

    pp._escape = spy
    result = pp.run(random_scene(seed=11))
    assert result.success, (result.failed_stage, result.reason)
    assert seen, "the retreat made no straight escape"
    (tip0, top0), _, _ = seen[0]
    # The case this guards: after the release the fingertips reach well down beside the object.
    assert top0 - tip0 > 0.025
    _, (tip1, top1), out = seen[-1]
    # After the straight part the fingertips are above the object's top (the pipeline's clearance is 10 mm;
    # 5 mm of it is allowed for tracking and the object settling).
    assert tip1 > top1 + 0.005, (tip1, top1, out)
    # The retreat stage reports how far the fingers reached below the top, matching the hand derivation
    # within the finger box's tilt allowance and the object's settling (2 mm).
    retreat = next(s for s in result.stages if s.name == "retreat")
    assert abs(retreat.detail["fingers_below_top_mm"] - 1e3 * (top0 - tip0)) < 2.0
    assert np.isclose(retreat.detail["escape_distance_mm"], 1e3 * (tip1 - tip0), atol=3.0)
