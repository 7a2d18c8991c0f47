"""Table-top scenes for pick-and-place: the bundled Panda on a pedestal before a table with objects.

A :class:`SceneSpec` is plain data (objects with shapes and poses, the target, the place location, the
camera) drawn at random from a seed by :func:`random_scene`; :func:`build_world` turns it into a
simulated :class:`ferrobot.World` with the robot and a camera. World frame: z up, the table's front edge
along y; the robot's base sits on a pedestal at the table's height, so base and world frames differ by a
translation (every pose handed to the planner goes through :func:`ferrobot.transforms.world_to_base`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .. import _core, robots
from ..errors import InvalidArgumentError
from .clutter import BinSpec, add_bin, random_clutter, settle

__all__ = [
    "ObjectSpec",
    "SceneSpec",
    "random_scene",
    "clutter_scene",
    "build_world",
    "home_for",
    "robot_reach",
    "place_camera",
    "TABLE_TOP",
    "HOME",
]

#: Height (m) of the table's top face.
TABLE_TOP = 0.40
#: Table size (m): depth along x, width along y, height.
TABLE_SIZE = (0.70, 1.10, TABLE_TOP)
#: Table centre (x, y) in the world.
TABLE_XY = (0.60, 0.0)
#: Pose of the robot base in the world: on a pedestal whose top is level with the table.
BASE_POSE = np.array([0.0, 0.0, TABLE_TOP, 1.0, 0.0, 0.0, 0.0])
#: Home configuration of the arm (Franka's "ready" pose) with the fingers open.
HOME = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785, 0.04])
#: Region (world x, y) where objects and place locations are drawn.
REGION = ((0.38, 0.68), (-0.28, 0.28))
#: Name of the robot's mount (the pedestal under its base): the planner leaves it out of its world, since
#: the base link rests on it.
ROBOT_MOUNT = "pedestal"
#: Smallest gap (m) between objects' footprints (and the place location's).
GAP = 0.06

KINDS = ("box", "cylinder", "sphere")
COLORS = [
    (0.85, 0.25, 0.20),
    (0.20, 0.55, 0.85),
    (0.95, 0.75, 0.15),
    (0.35, 0.75, 0.35),
    (0.65, 0.35, 0.80),
    (0.95, 0.50, 0.15),
]


@dataclass
class ObjectSpec:
    """One object: ``kind`` box (``size`` = edge lengths), cylinder (``size`` = radius, length) or sphere
    (``size`` = radius); ``pose`` [x, y, z, qw, qx, qy, qz] in the world."""

    name: str
    kind: str
    size: tuple[float, ...]
    pose: list[float]
    mass: float = 0.15
    friction: float = 0.9
    color: tuple[float, float, float] = (0.6, 0.6, 0.6)
    #: kind "mesh": the mesh file and its scale (3,); ``size`` then holds the drop pose's bounding-box extents.
    mesh: str | None = None
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)

    @property
    def height(self) -> float:
        """Height (m) of the resting object."""
        if self.kind == "box":
            return self.size[2]
        if self.kind == "cylinder":
            return self.size[1]
        if self.kind == "mesh":
            return self.size[2]
        return 2 * self.size[0]

    @property
    def footprint(self) -> float:
        """Radius (m) of a circle around the object's footprint."""
        if self.kind in ("box", "mesh"):
            return 0.5 * math.hypot(self.size[0], self.size[1])
        return self.size[0]


@dataclass
class SceneSpec:
    """Everything that defines an episode's scene, as plain data (JSON-serialisable via :meth:`to_dict`)."""

    seed: int
    objects: list[ObjectSpec]
    target: str
    place_xy: tuple[float, float]
    camera_eye: tuple[float, float, float] = (1.15, 0.0, 1.15)
    camera_target: tuple[float, float, float] = (0.52, 0.0, TABLE_TOP)
    camera_size: tuple[int, int] = (640, 480)
    camera_f: float = 525.0
    base_pose: list[float] = field(default_factory=lambda: BASE_POSE.tolist())
    #: A bin on the table (``ferrobot.pipeline.clutter.BinSpec``) or None.
    bin: BinSpec | None = None

    def object(self, name: str) -> ObjectSpec:
        for o in self.objects:
            if o.name == name:
                return o
        raise InvalidArgumentError(f"scene has no object named '{name}'; objects: {[o.name for o in self.objects]}")

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def _object(rng: np.random.Generator, name: str, kind: str, color) -> ObjectSpec:
    if kind == "box":
        # Graspable across its shorter horizontal side (the hand opens to 8 cm).
        a = rng.uniform(0.035, 0.055)
        b = rng.uniform(0.035, 0.07)
        size = (a, b, rng.uniform(0.04, 0.09))
    elif kind == "cylinder":
        size = (rng.uniform(0.02, 0.03), rng.uniform(0.06, 0.11))
    else:
        size = (rng.uniform(0.025, 0.032),)
    return ObjectSpec(name=name, kind=kind, size=size, pose=[0, 0, 0, 1, 0, 0, 0], color=color)


def random_scene(seed: int, num_objects: int | None = None) -> SceneSpec:
    """A random table-top scene: 3-5 objects (boxes, cylinders, spheres) with random sizes, positions and
    yaw, one of them the target, and a free place location on the table. Deterministic in ``seed``."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 6)) if num_objects is None else int(num_objects)
    if not 1 <= n <= 6:
        raise InvalidArgumentError(f"num_objects: expected 1 to 6, got {n}")
    (x0, x1), (y0, y1) = REGION
    objects: list[ObjectSpec] = []
    taken: list[tuple[float, float, float]] = []  # (x, y, radius)

    def free_spot(radius: float) -> tuple[float, float] | None:
        for _ in range(200):
            x, y = rng.uniform(x0, x1), rng.uniform(y0, y1)
            if all(math.hypot(x - a, y - b) > radius + r + GAP for a, b, r in taken):
                return x, y
        return None

    kinds = list(rng.choice(KINDS, size=n, p=[0.45, 0.4, 0.15]))
    for i, kind in enumerate(kinds):
        o = _object(rng, f"{kind}_{i}", str(kind), COLORS[i % len(COLORS)])
        spot = free_spot(o.footprint)
        if spot is None:
            continue
        yaw = rng.uniform(-math.pi, math.pi) if kind == "box" else 0.0
        o.pose = [spot[0], spot[1], TABLE_TOP + o.height / 2, math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
        objects.append(o)
        taken.append((spot[0], spot[1], o.footprint))
    target = objects[int(rng.integers(len(objects)))]
    place = free_spot(target.footprint + 0.02)
    if place is None:  # crowded: retry with another draw
        return random_scene(seed + 100_003, num_objects)
    return SceneSpec(seed=seed, objects=objects, target=target.name, place_xy=(float(place[0]), float(place[1])))


def home_for(model, gripper=None) -> np.ndarray:
    """The start configuration of ``model`` in the scenes: ``HOME`` for a Panda-like model (7 arm joints and
    the finger joint), else the SRDF's first named state (the neutral configuration without one) with the
    gripper (``ferrobot.Gripper.from_model`` when not given; none when the model has none) open."""
    names = list(model.dof_names)
    if len(names) == len(HOME) and names[-1] == "panda_finger_joint1":
        return HOME.copy()
    states = model.named_states  # (group, name) pairs, SRDF order
    q = model.named_state(states[0][1], group=states[0][0]) if states else model.neutral_configuration()
    q = np.asarray(q, dtype=float).copy()
    if gripper is None:
        try:
            gripper = _core.Gripper.from_model(model)
        except Exception:  # no gripper: nothing to open
            gripper = None
    if gripper is not None:
        q[names.index(gripper.driver)] = gripper.open_position
    return q


#: Smallest clearance (m) between the scene camera and the sphere the robot's TCP can reach (:func:`place_camera`).
CAMERA_CLEARANCE = 0.05
_REACH: dict = {}


def robot_reach(model, gripper=None, samples: int = 4096) -> float:
    """The robot's reach (m): the largest distance from its base frame's origin to its TCP (``gripper``'s, or
    the end-effector link's origin without one) over ``samples`` configurations drawn uniformly within the
    joint limits (unbounded joints: +-pi) from a fixed seed. Cached per model and gripper."""
    key = (id(model), None if gripper is None else (gripper.hand_link, tuple(np.round(gripper.tcp, 9))), samples)
    hit = _REACH.get(key)
    if hit is not None and hit[0] is model:
        return hit[1]
    lo = np.where(np.isfinite(model.lower_limits), model.lower_limits, -math.pi)
    hi = np.where(np.isfinite(model.upper_limits), model.upper_limits, math.pi)
    q = np.random.default_rng(0).uniform(lo, hi, (samples, len(lo)))
    if gripper is None:
        p = model.fk_batch(q)[:, :3]
    else:
        poses = model.fk_batch(q, gripper.hand_link)
        w, x, y, z = poses[:, 3], poses[:, 4], poses[:, 5], poses[:, 6]
        rot = np.stack(
            [
                np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
            ],
            1,
        )
        p = poses[:, :3] + rot @ np.asarray(gripper.tcp, dtype=np.float64)
    reach = float(np.linalg.norm(p, axis=1).max())
    _REACH[key] = (model, reach)
    return reach


def place_camera(spec: SceneSpec, model, gripper=None, clearance: float = CAMERA_CLEARANCE) -> SceneSpec:
    """Places ``spec``'s scene camera for ``model`` (in place; returns ``spec``): it keeps looking at the
    workspace (``camera_target``) along the same ray, and is moved back along that ray until it lies at least
    ``clearance`` beyond the robot's reach (:func:`robot_reach`) from the robot's base (``spec.base_pose``),
    so the arm can neither hit nor fill the view. The default eye (1.15, 0, 1.15) clears arms of up to 1.32 m
    reach from their base origin (the bundled Panda with its hand: 1.27 m, UR5e + 2F-85: 1.22 m) and is kept
    for them; a longer arm gets the eye moved back."""
    eye = clear_of_reach(spec.camera_eye, spec.camera_target, spec.base_pose[:3], model, gripper, clearance)
    if eye is not None:
        spec.camera_eye = eye
    return spec


def clear_of_reach(eye, target, base, model, gripper=None, clearance: float = CAMERA_CLEARANCE):
    """The camera eye looking at ``target`` moved back along its ray until it is ``clearance`` beyond the
    reach (:func:`robot_reach`) of ``model`` standing at ``base`` (world x, y, z); None when ``eye`` already
    is (so a camera the arm cannot reach is left exactly where it is)."""
    if not (math.isfinite(clearance) and clearance >= 0):
        raise InvalidArgumentError(f"clearance: expected a finite distance >= 0 (m), got {clearance}")
    need = robot_reach(model, gripper) + clearance
    base = np.asarray(base, dtype=float)
    eye, target = np.asarray(eye, dtype=float), np.asarray(target, dtype=float)
    if np.linalg.norm(eye - base) >= need:
        return None
    ray = eye - target
    ray /= np.linalg.norm(ray)
    # |target + d ray - base| = need: the larger root of d^2 + 2 d ray.(target - base) + |target - base|^2 - need^2.
    b = float(ray @ (target - base))
    c = float((target - base) @ (target - base)) - need * need
    d = -b + math.sqrt(max(b * b - c, 0.0))
    return tuple((target + d * ray).tolist())


def build_world(spec: SceneSpec, model=None, q=None, name: str = "panda"):
    """The simulated world of ``spec``: (world, robot, camera). The robot starts at ``q`` (default
    :func:`home_for`: ``HOME`` for the Panda) with open fingers; objects settle for 0.25 s before the
    world's initial state is marked."""
    model = robots.panda() if model is None else model
    home = home_for(model) if q is None else np.asarray(q, dtype=float)
    world = _core.World()
    tx, ty = TABLE_XY
    world.add_box("table", TABLE_SIZE, [tx, ty, TABLE_TOP / 2, 1, 0, 0, 0], fixed=True, color=(0.55, 0.42, 0.30))
    world.add_box(
        ROBOT_MOUNT, (0.3, 0.3, TABLE_TOP), [0.0, 0.0, TABLE_TOP / 2, 1, 0, 0, 0], fixed=True, color=(0.3, 0.3, 0.32)
    )
    for o in spec.objects:
        common = dict(mass=o.mass, friction=o.friction, color=o.color)
        if o.kind == "box":
            world.add_box(o.name, o.size, o.pose, **common)
        elif o.kind == "cylinder":
            world.add_cylinder(o.name, o.size[0], o.size[1], o.pose, **common)
        elif o.kind == "sphere":
            world.add_sphere(o.name, o.size[0], o.pose, **common)
        elif o.kind == "mesh":
            world.add_mesh_file(o.name, o.mesh, o.pose, scale=o.scale, **common)
            world.step(24)  # dropped one by one: a pile
        else:
            raise InvalidArgumentError(f"object '{o.name}': unknown kind '{o.kind}' (box, cylinder, sphere, mesh)")
    if spec.bin is not None:
        add_bin(world, spec.bin if isinstance(spec.bin, BinSpec) else BinSpec(**spec.bin), TABLE_TOP)
    if any(o.kind == "mesh" for o in spec.objects):
        settle(world, [o.name for o in spec.objects if o.kind == "mesh"])
    robot = world.add_robot(model, spec.base_pose, name=name, q=home)
    robot.set_joint_position_targets(home)
    w, h = spec.camera_size
    pose = _core.look_at(spec.camera_eye, spec.camera_target)
    camera = _core.Camera(world, w, h, spec.camera_f, spec.camera_f, (w - 1) / 2, (h - 1) / 2, pose)
    world.step(60)
    world.mark_initial_state()
    return world, robot, camera


#: Centre (x, y) of clutter piles and bins, and the place location of clutter scenes.
CLUTTER_CENTER = (0.55, 0.09)
CLUTTER_PLACE = (0.50, -0.22)


def clutter_scene(seed: int, num_objects: int = 8, objects=None, *, bin: bool = False, target: str | None = None):
    """A clutter scene for pick-and-place: ``num_objects`` mesh objects from ``objects`` (a folder of URDFs /
    meshes; default pybullet_data's, see :func:`ferrobot.pipeline.clutter.random_clutter`) dropped in a pile
    (or a bin) at :data:`CLUTTER_CENTER`; the target is ``target`` (an object name) or the last object
    dropped (on top of the pile); the place location :data:`CLUTTER_PLACE` is clear of the pile."""
    c = random_clutter(seed, num_objects, objects, bin=bin, table_top=TABLE_TOP, center=CLUTTER_CENTER)
    objs = []
    for o in c.objects:
        info = _core.load_mesh(o.mesh, o.scale)
        q = np.asarray(o.pose[3:])
        w, x, y, z = q
        r = np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
            ]
        )
        v = info.vertices @ r.T
        ext = tuple(float(e) for e in v.max(axis=0) - v.min(axis=0))
        objs.append(
            ObjectSpec(
                name=o.name,
                kind="mesh",
                size=ext,
                pose=o.pose,
                mass=o.mass,
                friction=o.friction,
                color=o.color,
                mesh=o.mesh,
                scale=o.scale,
            )
        )
    names = [o.name for o in objs]
    if target is not None and target not in names:
        raise InvalidArgumentError(f"target: the scene has no object '{target}'; objects: {names}")
    return SceneSpec(
        seed=seed,
        objects=objs,
        target=target or names[-1],
        place_xy=CLUTTER_PLACE,
        bin=c.bin,
        camera_target=(CLUTTER_CENTER[0], CLUTTER_CENTER[1], TABLE_TOP),
    )
