"""The one definition of a successful place (pipeline ``verify`` and ``PickPlaceEnv``), by hand-derived cases."""

from __future__ import annotations

import pytest

from ferrobot.pipeline.pick_place import REST_SPEED, UPRIGHT_TOLERANCE, placement_failure

PLACE = (0.5, -0.2)
REST_Z = 0.425  # a 5 cm box on a 0.4 m table


@pytest.mark.parametrize(
    ("position", "speed", "kind", "cause"),
    [
        ((0.5, -0.2, REST_Z), 0.0, "box", ""),
        ((0.52, -0.18, REST_Z), 0.0, "box", ""),  # 28.3 mm off: inside 30 mm
        ((0.53, -0.18, REST_Z), 0.0, "box", "not_at_place"),  # 36.1 mm off
        ((0.5, -0.2, REST_Z + 0.02), 0.0, "box", "not_resting"),  # tipped over / on something
        ((0.5, -0.2, REST_Z + 0.02), 0.0, "sphere", ""),  # no upright pose for spheres and meshes
        ((0.5, -0.2, REST_Z + 0.02), 0.0, "mesh", ""),
        ((0.5, -0.2, REST_Z), REST_SPEED * 1.5, "cylinder", "not_resting"),  # still rolling
        ((0.5, -0.2, REST_Z), REST_SPEED * 1.5, "mesh", "not_resting"),
        ((0.5, -0.2, REST_Z + UPRIGHT_TOLERANCE * 0.5), REST_SPEED * 0.5, "box", ""),
    ],
)
def test_placement_criterion(position, speed, kind, cause):
    got, message = placement_failure(position, speed, REST_Z, PLACE, kind, 0.03)
    assert got == cause
    assert bool(message) == bool(cause)


def test_the_environment_uses_the_pipeline_criterion():
    from ferrobot.envs import tasks

    assert tasks.placement_failure is placement_failure
