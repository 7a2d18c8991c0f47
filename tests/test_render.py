"""Lighting of rendered RGB images (Lambert shading against a hand derivation) and the generator's seeded
rendering randomisation (lighting, wrist camera mount jitter)."""

import math

import numpy as np
import pytest

import ferrobot
from ferrobot.errors import FerrobotError

COLOR = (0.8, 0.6, 0.4)
W, H = 65, 49  # odd: the principal point (32, 24) is a pixel centre, its ray along the optical axis


def _top_view(**lighting):
    """A static box whose top face (z = 0.05, normal +z) fills the view of a camera 1 m above it looking down."""
    w = ferrobot.World(ground=False)
    w.add_box("slab", (2.0, 2.0, 0.1), np.eye(4), fixed=True, color=COLOR)
    if lighting:
        w.set_lighting(**lighting)
    pose = ferrobot.look_at((0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    cam = ferrobot.Camera(w, W, H, 50.0, 50.0, (W - 1) / 2, (H - 1) / 2, pose)
    return w, cam.render()


@pytest.mark.parametrize("theta_deg", [0.0, 30.0, 60.0, 85.0, 95.0, 150.0])
def test_directional_light_follows_the_cosine_law(theta_deg):
    """A light travelling at angle theta to -z (the face's normal is +z) lights the face by I cos(theta), and
    not at all past 90 degrees: pixel = trunc(255 * albedo * (ambient + I * colour * max(0, cos theta)))."""
    th = math.radians(theta_deg)
    direction = (math.sin(th), 0.0, -math.cos(th))
    light_color, intensity, ambient = (1.0, 0.5, 0.25), 0.9, 0.1
    _, f = _top_view(ambient=(ambient,) * 3, headlight=0.0, lights=[(direction, light_color, intensity)])
    assert np.all(np.isfinite(f.depth))
    cos = max(0.0, math.cos(th))
    want = [math.floor(255 * a * (ambient + intensity * lc * cos)) for a, lc in zip(COLOR, light_color, strict=True)]
    rgb = f.rgb.reshape(-1, 3).astype(int)
    # Flat face, directional light: every pixel the same; f32 rounding may move the truncation by one.
    assert np.abs(rgb - np.array(want)).max() <= 1, (rgb[0], want)


def test_headlight_and_ambient_and_defaults():
    w, f = _top_view(ambient=(0.2, 0.3, 0.4), headlight=0.5, lights=[])
    centre = f.rgb[(H - 1) // 2, (W - 1) // 2].astype(int)
    want = [math.floor(255 * a * (amb + 0.5)) for a, amb in zip(COLOR, (0.2, 0.3, 0.4), strict=True)]
    assert np.abs(centre - want).max() <= 1
    # Off-centre pixels see the face at an angle: cos = 1 / |ray|.
    u, v = 0, 0
    r = math.hypot((u - 32) / 50.0, (v - 24) / 50.0, 1.0)
    corner = f.rgb[v, u].astype(int)
    want = [math.floor(255 * a * (amb + 0.5 / r)) for a, amb in zip(COLOR, (0.2, 0.3, 0.4), strict=True)]
    assert np.abs(corner - want).max() <= 1
    # Lighting changes RGB only.
    _, g = _top_view()
    np.testing.assert_array_equal(f.depth, g.depth)
    np.testing.assert_array_equal(f.segmentation, g.segmentation)
    lt = ferrobot.World(ground=False).lighting.to_dict()
    assert lt == {"ambient": [0.35] * 3, "headlight": 0.65, "lights": []}


@pytest.mark.parametrize(
    "kwargs, word",
    [
        ({"ambient": (1.5, 0, 0)}, "ambient"),
        ({"headlight": -0.1}, "headlight"),
        ({"headlight": float("nan")}, "headlight"),
        ({"lights": [((0, 0, 0), (1, 1, 1), 1.0)]}, "direction"),
        ({"lights": [((0, 0, -1), (1, 2, 1), 1.0)]}, "color"),
        ({"lights": [((0, 0, -1), (1, 1, 1), 11.0)]}, "intensity"),
        ({"lights": [((0, 0, -1), (1, 1, 1), 1.0)] * 9}, "at most 8"),
        ({"ambient": (1, 1)}, "ambient"),
    ],
)
def test_bad_lighting_is_refused_and_keeps_the_previous(kwargs, word):
    w = ferrobot.World(ground=False)
    w.set_lighting(ambient=(0.1, 0.2, 0.3), headlight=0.4, lights=[((0, 0, -1), (1, 1, 1), 0.5)])
    before = w.lighting.to_dict()
    with pytest.raises(FerrobotError, match=word):
        w.set_lighting(**kwargs)
    assert w.lighting.to_dict() == before


def test_generation_randomises_lighting_and_wrist_camera_deterministically():
    from ferrobot.control import WRIST_EYE, WRIST_TARGET, make_cameras
    from ferrobot.dataset.generate import apply_lighting, episode_cameras, episode_spec, parse_cameras
    from ferrobot.pipeline import build_world

    cfg = {"clutter": None, "randomize": True, "cameras": parse_cameras("scene:32x24,wrist:16x12")}
    draws = [episode_spec(cfg, s)[1] for s in (1, 2, 1)]
    assert draws[0] == draws[2] and draws[0] != draws[1]
    for rand in draws:
        lt = rand["lighting"]
        assert all(0.12 <= a <= 0.38 for a in lt["ambient"]) and 0.1 <= lt["headlight"] <= 0.3
        ((d, c, i),) = lt["lights"]
        assert math.isclose(np.linalg.norm(d), 1.0) and d[2] < -math.sin(math.radians(24))
        assert all(0.8 <= x <= 1.0 for x in c) and 0.3 <= i <= 0.7
        wc = rand["wrist_camera"]
        assert np.abs(np.subtract(wc["eye"], WRIST_EYE)).max() <= 0.005
        assert np.abs(np.subtract(wc["target"], WRIST_TARGET)).max() <= 0.01
    # Applied: the world's lighting and the wrist camera's pose on the hand are the drawn ones.
    spec, rand = episode_spec(cfg, 1)
    world, robot, camera = build_world(spec)
    apply_lighting(world, rand)
    assert world.lighting.lights[0][2] == rand["lighting"]["lights"][0][2]
    assert world.lighting.ambient == rand["lighting"]["ambient"]
    cams = make_cameras(world, robot, camera.world_transform, episode_cameras(cfg, rand))
    wc = rand["wrist_camera"]
    want = robot.get_link_pose("panda_hand") @ ferrobot.look_at(wc["eye"], wc["target"], (1, 0, 0))
    np.testing.assert_allclose(cams["wrist"].world_transform, want, atol=1e-9)
    # Without randomisation: default lighting and the nominal wrist pose.
    spec0, rand0 = episode_spec({**cfg, "randomize": False}, 1)
    assert rand0 == {}
    (wrist,) = [s for s in episode_cameras(cfg, rand0) if s.name == "wrist"]
    assert wrist.link is None and wrist.pose is None
