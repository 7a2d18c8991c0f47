"""Batch generation of recorded pick-and-place episodes into a LeRobot v3.0 or robomimic HDF5 dataset.

Guarantees (tested in ``tests/test_generate.py``):

* **Deterministic per episode**: episode ``i`` uses the seed ``episode_seed(seed, i)`` for its scene and its
  domain randomisation, whatever worker runs it and in whatever order.
* **Nothing half-written is visible**: an episode is written to ``<out>/.ferrobot/tmp/`` and published by one
  rename into ``<out>/.ferrobot/episodes/ep-XXXXXX``; a retried episode finding itself published keeps the
  first copy (both are the same).
* **Nothing lost**: a worker killed mid-episode (the local pool breaks, or Ray's task fails) has its episode
  run again (up to ``max_retries`` times); killing the whole run and re-running the same command resumes:
  published episodes are kept, the rest are run.
* **Metadata from the published episodes only**: finalisation reads ``.ferrobot/episodes`` in episode order,
  builds the dataset in ``.ferrobot/work`` and moves it into place; ``.ferrobot/done.json`` marks completion
  (a kill during finalisation leaves no marker: the next run finalises again from scratch).
* **Existing data is never touched by a bad command**: a directory holding other files, or a ferrobot dataset
  made with another configuration, is refused before anything is written.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import sys
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FerrobotError, InvalidArgumentError

__all__ = ["GenerateConfig", "generate", "episode_seed", "run_episode", "FORMATS", "parse_cameras", "scene_from_dict"]

FORMATS = ("lerobot", "hdf5")
#: Bundled robots by name (``--robot`` also takes a URDF path, with ``--srdf``).
ROBOTS = ("panda", "ur5e")
#: Shipped grippers by name (``--gripper``; default: the robot's own, ``ferrobot.Gripper.from_model``).
GRIPPERS = ("panda_hand", "robotiq_2f85")
#: Mesh objects per scene with ``--objects``: default and range (``--clutter``).
DEFAULT_MESH_OBJECTS = 5
MAX_MESH_OBJECTS = 15
STATE_DIR = ".ferrobot"
_KILL_ENV = "FERROBOT_GENERATE_FAULT"  # test hook: "worker:<episode>:<marker file>" or "finalize"


def episode_seed(seed: int, index: int, attempt: int = 0) -> int:
    """The scene seed of episode ``index`` of a run seeded ``seed`` (independent of scheduling). ``attempt``
    counts scenes where the pipeline failed before the robot moved (nothing to record: the perception,
    detection or grasp selection found nothing): the episode then uses the next attempt's scene."""
    return int(np.random.SeedSequence([int(seed), int(index), int(attempt)]).generate_state(1)[0])


#: Scenes tried per episode before giving up on recording anything.
MAX_ATTEMPTS = 10


def scene_fov(spec) -> float:
    """Horizontal field of view (degrees) of the scene's perception camera."""
    return 2 * math.degrees(math.atan(0.5 * spec.camera_size[0] / spec.camera_f))


def scene_from_dict(d: dict):
    """The :class:`~ferrobot.pipeline.SceneSpec` stored in an episode's metadata (LeRobot: the episodes
    table's ``scene`` column; HDF5: ``data/demo_N`` attribute ``model_file``), for replaying its actions."""
    from ..pipeline import ObjectSpec, SceneSpec

    d = dict(d)
    objects = [ObjectSpec(**{**o, "size": tuple(o["size"]), "color": tuple(o["color"])}) for o in d.pop("objects")]
    return SceneSpec(
        objects=objects,
        **{
            **d,
            "place_xy": tuple(d["place_xy"]),
            "camera_eye": tuple(d["camera_eye"]),
            "camera_target": tuple(d["camera_target"]),
            "camera_size": tuple(d["camera_size"]),
        },
    )


_ROBOT_CACHE: dict = {}


def resolve_robot(cfg: dict):
    """(model, gripper) of a generation config (``robot``, ``srdf``, ``gripper``), built once per process."""
    from ..pipeline.pick_place import resolve_robot as _resolve

    key = (cfg.get("robot", "panda"), cfg.get("srdf"), cfg.get("gripper"))
    if key not in _ROBOT_CACHE:
        _ROBOT_CACHE[key] = _resolve(key[0], key[1], key[2])
    return _ROBOT_CACHE[key]


def episode_spec(cfg: dict, seed: int):
    """The scene of an episode seeded ``seed`` under the generation config ``cfg``, and its randomisation.
    Procedural objects (:func:`~ferrobot.pipeline.random_scene`, ``clutter`` of them) or, with ``objects``
    (a folder of mesh / URDF object files), a pile of ``clutter`` mesh objects
    (:func:`~ferrobot.pipeline.clutter_scene`, default :data:`DEFAULT_MESH_OBJECTS`); the scene camera placed
    for the robot's reach (:func:`~ferrobot.pipeline.scene.place_camera`)."""
    from ..pipeline import random_scene
    from ..pipeline.scene import clutter_scene, place_camera

    if cfg.get("objects"):
        spec = clutter_scene(seed, cfg["clutter"] or DEFAULT_MESH_OBJECTS, cfg["objects"])
    else:
        spec = random_scene(seed, cfg["clutter"])
    model, gripper = resolve_robot(cfg)
    place_camera(spec, model, gripper)
    rand = randomize_scene(spec, seed, gripper) if cfg["randomize"] else {}
    return spec, rand


def parse_cameras(text: str) -> list[dict]:
    """``"scene:640x480,wrist:320x240"`` -> [{"name", "width", "height"}]. Names: scene, wrist."""
    out = []
    for part in [p.strip() for p in text.split(",") if p.strip()]:
        name, _, size = part.partition(":")
        if name not in ("scene", "wrist"):
            raise InvalidArgumentError(f"cameras: unknown camera '{name}' (supported: scene, wrist)")
        if size:
            try:
                w, h = (int(x) for x in size.lower().split("x"))
            except ValueError:
                raise InvalidArgumentError(f"cameras: expected NAME:WIDTHxHEIGHT, got '{part}'") from None
        else:
            from ..control import DEFAULT_CAMERAS

            w, h = DEFAULT_CAMERAS[name]
        if not (8 <= w <= 4096 and 8 <= h <= 4096):
            raise InvalidArgumentError(f"cameras: {name} size must be 8 to 4096 pixels a side, got {w}x{h}")
        if any(c["name"] == name for c in out):
            raise InvalidArgumentError(f"cameras: '{name}' given twice")
        out.append({"name": name, "width": w, "height": h})
    if not out:
        raise InvalidArgumentError("cameras: at least one camera is needed")
    return out


@dataclass
class GenerateConfig:
    """What defines a dataset (stored in ``.ferrobot/config.json``; a re-run must match it)."""

    episodes: int
    seed: int = 0
    format: str = "lerobot"
    #: "panda", "ur5e" (bundled) or a URDF path (stored absolute); ``srdf`` beside a URDF path.
    robot: str = "panda"
    clutter: int | None = None
    srdf: str | None = None
    #: "panda_hand", "robotiq_2f85", or None (the robot's own gripper).
    gripper: str | None = None
    #: A folder of mesh / URDF objects (stored absolute): scenes are piles of ``clutter`` of them.
    objects: str | None = None
    cameras: list = field(default_factory=lambda: parse_cameras("scene:640x480,wrist:320x240"))
    control_hz: int = 10
    randomize: bool = True
    segmentation: bool = True

    def validate(self) -> None:
        if self.format not in FORMATS:
            raise InvalidArgumentError(f"format: unknown format '{self.format}' (expected one of {', '.join(FORMATS)})")
        if not (isinstance(self.episodes, int) and 1 <= self.episodes <= 10_000_000):
            raise InvalidArgumentError(f"episodes: expected an integer in [1, 10000000], got {self.episodes!r}")
        if not (isinstance(self.seed, int) and 0 <= self.seed < 2**63):
            raise InvalidArgumentError(f"seed: expected an integer in [0, 2^63), got {self.seed!r}")
        if self.robot not in ROBOTS:
            if not (self.robot.endswith(".urdf") and os.path.isfile(self.robot)):
                raise InvalidArgumentError(
                    f"robot: expected one of {', '.join(ROBOTS)} or a URDF file path, got '{self.robot}'"
                )
            self.robot = os.path.abspath(self.robot)
        elif self.srdf is not None:
            raise InvalidArgumentError(f"srdf: only for a URDF path robot; '{self.robot}' is bundled with its own")
        if self.srdf is not None:
            if not os.path.isfile(self.srdf):
                raise InvalidArgumentError(f"srdf: no such file '{self.srdf}'")
            self.srdf = os.path.abspath(self.srdf)
        if self.gripper is not None and self.gripper not in GRIPPERS:
            raise InvalidArgumentError(f"gripper: expected one of {', '.join(GRIPPERS)}, got '{self.gripper}'")
        if self.objects is not None:
            if not os.path.isdir(self.objects):
                raise InvalidArgumentError(f"objects: '{self.objects}' is not a folder of object files")
            self.objects = os.path.abspath(self.objects)
            if self.clutter is not None and not 1 <= self.clutter <= MAX_MESH_OBJECTS:
                raise InvalidArgumentError(
                    f"clutter: expected 1 to {MAX_MESH_OBJECTS} mesh objects in the pile, got {self.clutter}"
                )
        elif self.clutter is not None and not 1 <= self.clutter <= 6:
            raise InvalidArgumentError(f"clutter: expected 1 to 6 objects on the table, got {self.clutter}")
        if self.control_hz not in (1, 2, 3, 4, 5, 6, 8, 10, 12, 15, 16, 20, 24, 30, 40, 48, 60, 80, 120, 240):
            raise InvalidArgumentError(f"control_hz: must divide the 240 Hz physics rate, got {self.control_hz}")

    def to_dict(self) -> dict:
        out = {
            "episodes": self.episodes,
            "seed": self.seed,
            "format": self.format,
            "robot": self.robot,
            "clutter": self.clutter,
            "cameras": self.cameras,
            "control_hz": self.control_hz,
            "randomize": self.randomize,
            "segmentation": self.segmentation,
        }
        # Only when set: configurations of datasets written before these options existed stay equal.
        for key in ("srdf", "gripper", "objects"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        return out


# -- domain randomisation -----------------------------------------------------------------------------------

COLOR_NAMES = {
    "red": (0.85, 0.2, 0.2),
    "green": (0.25, 0.7, 0.3),
    "blue": (0.2, 0.4, 0.85),
    "yellow": (0.92, 0.8, 0.15),
    "purple": (0.6, 0.3, 0.8),
    "orange": (0.95, 0.5, 0.15),
    "white": (0.9, 0.9, 0.9),
    "black": (0.12, 0.12, 0.12),
}


def color_name(rgb) -> str:
    return min(COLOR_NAMES, key=lambda n: sum((a - b) ** 2 for a, b in zip(COLOR_NAMES[n], rgb, strict=True)))


def randomize_scene(spec, seed: int, gripper=None) -> dict:
    """Applies seeded domain randomisation to ``spec`` in place; returns what was drawn (for the episode's
    metadata). Object colours: one of the named colours with +-0.05 jitter per channel; mass x U(0.7, 1.3);
    friction U(0.7, 1.0); scene camera eye jitter U(-0.03, 0.03) m per axis, look-at point U(-0.02, 0.02) m.
    Rendering (applied by :func:`episode_cameras` / :func:`apply_lighting`, not part of the scene): the
    lighting (:func:`random_lighting`) and the wrist camera's mount pose (:func:`random_wrist_camera`), drawn
    from a second stream of the same seed so that the scene draws above do not depend on them. ``gripper``:
    the :class:`ferrobot.Gripper` the wrist camera is mounted on (default the Panda hand)."""
    rng = np.random.default_rng([seed, 0xD0])
    names = list(COLOR_NAMES)
    objects = {}
    for o in spec.objects:
        base = COLOR_NAMES[names[int(rng.integers(len(names)))]]
        o.color = tuple(float(np.clip(c + rng.uniform(-0.05, 0.05), 0, 1)) for c in base)
        o.mass = float(o.mass * rng.uniform(0.7, 1.3))
        o.friction = float(rng.uniform(0.7, 1.0))
        objects[o.name] = {"color": list(o.color), "mass": o.mass, "friction": o.friction}
    eye = np.asarray(spec.camera_eye) + rng.uniform(-0.03, 0.03, 3)
    target = np.asarray(spec.camera_target) + rng.uniform(-0.02, 0.02, 3)
    spec.camera_eye, spec.camera_target = tuple(eye.tolist()), tuple(target.tolist())
    render_rng = np.random.default_rng([seed, 0xD1])
    return {
        "objects": objects,
        "camera_eye": list(spec.camera_eye),
        "camera_target": list(spec.camera_target),
        "lighting": random_lighting(render_rng),
        "wrist_camera": random_wrist_camera(render_rng, gripper),
    }


def random_lighting(rng) -> dict:
    """A random Lambert lighting (the keyword arguments of ``World.set_lighting``): grey ambient U(0.15, 0.35)
    with +-0.03 tint per channel, head light U(0.1, 0.3), one directional light from elevation U(25, 85)
    degrees above the horizon at azimuth U(0, 360) degrees, colour U(0.8, 1.0) per channel (warm to cool
    whites), intensity U(0.3, 0.7)."""
    grey = rng.uniform(0.15, 0.35)
    ambient = [float(np.clip(grey + rng.uniform(-0.03, 0.03), 0.0, 1.0)) for _ in range(3)]
    headlight = float(rng.uniform(0.1, 0.3))
    el, az = np.radians(rng.uniform(25.0, 85.0)), np.radians(rng.uniform(0.0, 360.0))
    # The light travels from the sky position (el, az) towards the origin.
    direction = [float(-np.cos(el) * np.cos(az)), float(-np.cos(el) * np.sin(az)), float(-np.sin(el))]
    color = [float(c) for c in rng.uniform(0.8, 1.0, 3)]
    intensity = float(rng.uniform(0.3, 0.7))
    return {"ambient": ambient, "headlight": headlight, "lights": [[direction, color, intensity]]}


def random_wrist_camera(rng, gripper=None) -> dict:
    """Wrist camera mount jitter (hand frame of ``gripper``, default the Panda hand): the eye moved U(-5, 5) mm
    and the look-at point U(-10, 10) mm per axis from :func:`ferrobot.control.wrist_mount` (a few degrees of
    rotation); ``up`` is the mount's up vector (left out when it is the Panda mount's (1, 0, 0), as in the
    records written before other grippers were supported)."""
    from ..control import wrist_mount

    eye0, target0, up = wrist_mount(gripper)
    eye = np.asarray(eye0) + rng.uniform(-0.005, 0.005, 3)
    target = np.asarray(target0) + rng.uniform(-0.01, 0.01, 3)
    out = {"eye": eye.tolist(), "target": target.tolist()}
    if tuple(up) != (1.0, 0.0, 0.0):
        out["up"] = list(up)
    return out


def apply_lighting(world, rand: dict) -> None:
    """Sets ``world``'s lighting to the episode's randomised lighting (default lighting without one)."""
    lt = rand.get("lighting")
    if lt is not None:
        world.set_lighting(
            ambient=lt["ambient"],
            headlight=lt["headlight"],
            lights=[(d, c, i) for d, c, i in lt["lights"]],
        )


def episode_cameras(cfg: dict, rand: dict, gripper=None) -> list:
    """The :class:`~ferrobot.control.CameraSpec` list of an episode: the configured cameras, the wrist camera
    on ``gripper``'s hand link (default the config's robot's gripper) at the episode's jittered mount pose
    when randomised (else without a link: :func:`ferrobot.control.make_cameras` mounts it at
    :func:`ferrobot.control.wrist_mount` of the gripper it is given)."""
    from .. import _core
    from ..control import CameraSpec

    specs = []
    for c in cfg["cameras"]:
        s = CameraSpec(c["name"], c["width"], c["height"])
        w = rand.get("wrist_camera")
        if s.name == "wrist" and w is not None:
            if gripper is None:
                gripper = resolve_robot(cfg)[1]
            s.link = gripper.hand_link
            # Recorded before the mount had an up vector: the Panda mount's (1, 0, 0).
            s.pose = _core.look_at(w["eye"], w["target"], tuple(w.get("up", (1.0, 0.0, 0.0))))
        specs.append(s)
    return specs


def task_text(spec) -> str:
    o = spec.object(spec.target)
    x, y = spec.place_xy
    what = "object" if o.kind == "mesh" else o.kind  # mesh objects: their names are indices ("obj_2")
    return f"pick up the {color_name(o.color)} {what} and place it at x={x:.2f} m, y={y:.2f} m"


# -- one episode (runs in a worker) -------------------------------------------------------------------------

_PP: dict = {}


def _fault(stage: str, index: int | None = None) -> None:
    """Test hook: ``FERROBOT_GENERATE_FAULT`` set to ``worker:<i>:<marker>`` kills the worker (SIGKILL) in
    the middle of episode ``i`` once (the marker file records that it happened); ``finalize`` kills the
    process in the middle of finalisation."""
    spec = os.environ.get(_KILL_ENV, "")
    if stage == "worker" and spec.startswith("worker:"):
        _, i, marker = spec.split(":", 2)
        if int(i) == index and not os.path.exists(marker):
            Path(marker).write_text(str(os.getpid()))
            os.kill(os.getpid(), signal.SIGKILL)
    if stage == "finalize" and spec == "finalize":
        os.kill(os.getpid(), signal.SIGKILL)


def episode_name(index: int) -> str:
    return f"ep-{index:06d}"


def run_episode(cfg: dict, index: int, root: str) -> dict:
    """Runs, records and publishes episode ``index``; returns its summary. Idempotent: an episode already
    published is not run again."""
    from ..control import make_cameras
    from ..pipeline import PickPlace, PickPlaceConfig
    from ..pipeline.recording import ControlRecorder
    from .staging import Hdf5EpisodeWriter, LeRobotEpisodeWriter

    staging = Path(root) / STATE_DIR
    name = episode_name(index)
    published = staging / "episodes" / name
    if published.exists():
        meta = json.loads((published / "episode.json").read_text())
        return {"index": index, "success": meta["success"], "length": meta["length"], "cached": True}
    t0 = time.perf_counter()
    key = (cfg.get("robot", "panda"), cfg.get("srdf"), cfg.get("gripper"))
    if key not in _PP:
        model, gripper = resolve_robot(cfg)
        _PP[key] = PickPlace(PickPlaceConfig(), robot=model, gripper=gripper)
    pp = _PP[key]
    fps = int(cfg["control_hz"])
    writer_cls = LeRobotEpisodeWriter if cfg["format"] == "lerobot" else Hdf5EpisodeWriter
    for attempt in range(MAX_ATTEMPTS):
        seed = episode_seed(cfg["seed"], index, attempt)
        spec, rand = episode_spec(cfg, seed)
        specs = episode_cameras(cfg, rand, pp.gripper)
        writer = writer_cls(staging, name, fps)
        frames = [0]
        labels: dict = {}

        def sink(frame, writer=writer, frames=frames):
            writer(frame)
            frames[0] += 1
            if frames[0] == 3:
                _fault("worker", index)

        def factory(world, robot, camera, arm_idx, spec=spec, sink=sink, specs=specs, rand=rand, labels=labels):
            apply_lighting(world, rand)
            labels.update({str(k): v for k, v in world.segmentation_labels.items()})
            cameras = make_cameras(
                world, robot, camera.world_transform, specs, scene_fov_deg=scene_fov(spec), gripper=pp.gripper
            )
            return ControlRecorder(
                world,
                robot,
                cameras,
                sink,
                control_hz=fps,
                arm_joint_names=[robot.dof_names[i] for i in arm_idx],
                grip_force=pp.config.grip_force,
                segmentation=cfg["segmentation"],
                gripper=pp.gripper,
            )

        try:
            result = pp.run(spec, recorder=factory)
            if frames[0] == 0:
                writer.abort()
                continue
            meta = {
                "episode_index": index,
                "seed": seed,
                "attempt": attempt,
                "task": task_text(spec),
                "success": bool(result.success),
                "failed_stage": result.failed_stage,
                "reason": result.reason,
                "stages": result.episode.recorder.stage_bounds,
                "randomization": rand,
                "scene": spec.to_dict(),
                "result": result.to_dict(),
                "segmentation_labels": labels,
            }
            writer.finish(meta)
        except BaseException:
            writer.abort()
            raise
        return {
            "index": index,
            "success": bool(result.success),
            "length": frames[0],
            "wall_s": time.perf_counter() - t0,
            "cached": False,
        }
    raise FerrobotError(
        f"episode {index}: {MAX_ATTEMPTS} scenes in a row failed before the robot moved "
        f"(last: {result.failed_stage}: {result.reason})"
    )


def _init_worker(threads: int) -> None:
    os.environ["RAYON_NUM_THREADS"] = str(threads)


# -- the run --------------------------------------------------------------------------------------------------


class _Bar:
    """Progress: episodes done, success rate, episodes per hour (a line per 10% when not a terminal)."""

    def __init__(self, total: int, done: int, stream=None):
        self.total, self.start_done = total, done
        self.stream = sys.stderr if stream is None else stream
        self.tty = self.stream.isatty() if hasattr(self.stream, "isatty") else False
        self.t0 = time.perf_counter()
        self.last = -1

    def update(self, done: int, ok: int) -> None:
        el = time.perf_counter() - self.t0
        new = done - self.start_done
        rate = 3600.0 * new / el if el > 0 and new > 0 else 0.0
        fill = int(30 * done / self.total)
        text = (
            f"[{'#' * fill}{'.' * (30 - fill)}] {done}/{self.total} episodes, success {ok}/{max(done, 1)} "
            f"({100.0 * ok / max(done, 1):.0f}%), {rate:.0f} episodes/h"
        )
        if self.tty:
            self.stream.write("\r" + text + ("\n" if done == self.total else ""))
            self.stream.flush()
        elif 10 * done // self.total != self.last or done == self.total:
            self.last = 10 * done // self.total
            print(text, file=self.stream, flush=True)


def _prepare(out: Path, cfg: dict) -> Path:
    """Checks ``out`` (never modifying existing data on error) and returns the state directory."""
    if out.exists() and not out.is_dir():
        raise InvalidArgumentError(f"out: '{out}' exists and is not a directory")
    state = out / STATE_DIR
    conf = state / "config.json"
    if out.exists():
        if conf.exists():
            old = json.loads(conf.read_text())
            if old != cfg:
                diff = {k: (old.get(k), cfg.get(k)) for k in set(old) | set(cfg) if old.get(k) != cfg.get(k)}
                raise InvalidArgumentError(
                    f"out: '{out}' holds a dataset generated with another configuration "
                    f"(differences, existing vs requested: {diff}); use another directory"
                )
        elif any(out.iterdir()):
            raise InvalidArgumentError(
                f"out: '{out}' is not empty and holds no ferrobot dataset; refusing to write into it"
            )
    try:
        (state / "episodes").mkdir(parents=True, exist_ok=True)
        (state / "tmp").mkdir(exist_ok=True)
        if not conf.exists():
            tmp = state / "config.json.tmp"
            tmp.write_text(json.dumps(cfg, indent=2))
            os.replace(tmp, conf)
    except OSError as e:
        raise InvalidArgumentError(f"out: cannot write to '{out}': {e}") from e
    return state


def _published(state: Path, n: int) -> set[int]:
    return {i for i in range(n) if (state / "episodes" / episode_name(i)).is_dir()}


def _run_local(cfg: dict, root: str, todo: list[int], workers: int, on_done, max_retries: int) -> None:
    threads = max(1, (os.cpu_count() or 1) // workers)
    if workers == 1:
        os.environ.setdefault("RAYON_NUM_THREADS", str(threads))
        for i in todo:
            on_done(run_episode(cfg, i, root))
        return
    import multiprocessing

    attempts = dict.fromkeys(todo, 0)
    pending = list(todo)
    reported: set[int] = set()

    def report(r: dict) -> None:
        reported.add(r["index"])
        on_done(r)

    while pending:
        ctx = multiprocessing.get_context("spawn")
        broken = False
        with ProcessPoolExecutor(workers, mp_context=ctx, initializer=_init_worker, initargs=(threads,)) as pool:
            futures = {pool.submit(run_episode, cfg, i, root): i for i in pending}
            for i in pending:
                attempts[i] += 1
            remaining = set(futures)
            while remaining:
                done, remaining = wait(remaining, return_when=FIRST_COMPLETED)
                for f in done:
                    try:
                        report(f.result())
                    except BrokenProcessPool:
                        broken = True
        if not broken:
            return
        # A worker died (killed): every episode not published is retried in a fresh pool.
        published = _published(Path(root) / STATE_DIR, max(todo) + 1)
        for i in sorted(published & set(pending) - reported):
            report(run_episode(cfg, i, root))  # published before the pool broke: read back, not run
        pending = [i for i in pending if i not in published]
        for i in pending:
            if attempts[i] > max_retries:
                raise FerrobotError(f"episode {i}: its worker died {attempts[i]} times; giving up")


def _run_ray(cfg: dict, root: str, todo: list[int], address: str | None, workers: int | None, on_done, max_retries):
    import ray

    if not ray.is_initialized():
        kwargs = {"address": address} if address else {"num_cpus": workers} if workers else {}
        try:
            ray.init(include_dashboard=False, log_to_driver=False, **kwargs)
        except Exception as e:  # Ray raises ConnectionError, ValueError, RuntimeError... for a bad address
            where = f"the cluster at '{address}'" if address else "a local Ray instance"
            raise FerrobotError(f"ray: could not start or join {where}: {type(e).__name__}: {e}") from e
    task = ray.remote(num_cpus=1, max_retries=max_retries, retry_exceptions=False)(run_episode)
    refs = [task.options(runtime_env={"env_vars": {"RAYON_NUM_THREADS": "1"}}).remote(cfg, i, root) for i in todo]
    while refs:
        ready, refs = ray.wait(refs, num_returns=1)
        for r in ready:
            on_done(ray.get(r))


def generate(
    out,
    config: GenerateConfig,
    *,
    workers: int | None = None,
    ray: str | None = "auto",
    progress: bool = True,
    max_retries: int = 3,
) -> dict:
    """Generates ``config.episodes`` recorded episodes into ``out`` (resuming a previous run of the same
    configuration); returns the summary (also written to ``out/summary.json``).

    ``ray``: "auto" (Ray when installed, else a local process pool), "off" (local pool), or a cluster
    address ("HOST:PORT" or "auto" semantics of ``ray.init``). ``workers``: local processes (default: one per
    core); with Ray, the number of CPUs of a local Ray instance.
    """
    config.validate()
    # The robot and its gripper load here, before anything is written: a URDF without a gripper the
    # workflow can use, or a gripper that does not fit the robot, fails now with the library's error.
    resolve_robot(config.to_dict())
    if workers is not None and not (isinstance(workers, int) and 1 <= workers <= 4096):
        raise InvalidArgumentError(f"workers: expected an integer in [1, 4096], got {workers!r}")
    if not (isinstance(max_retries, int) and 0 <= max_retries <= 100):
        raise InvalidArgumentError(f"max_retries: expected an integer in [0, 100], got {max_retries!r}")
    needed = ("pyarrow", "av", "pandas") if config.format == "lerobot" else ("h5py",)
    for mod in needed:
        try:
            __import__(mod)
        except ImportError:
            raise InvalidArgumentError(
                f"format: '{config.format}' needs the Python package '{mod}': pip install 'ferrobot[dataset]'"
            ) from None
    use_ray, address = False, None
    if ray not in (None, "off"):
        try:
            import ray as _ray  # noqa: F401

            use_ray = True
            address = None if ray == "auto" else ray
        except ImportError:
            if ray != "auto":
                raise InvalidArgumentError(
                    f"ray: '{ray}' requested but Ray is not installed (pip install 'ferrobot[ray]')"
                ) from None
    out = Path(out)
    cfg = config.to_dict()
    state = _prepare(out, cfg)
    import fcntl

    lock = (state / "lock").open("w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        lock.close()
        raise InvalidArgumentError(f"out: another 'ferrobot generate' is writing to '{out}'") from None
    try:
        return _generate(out, config, cfg, state, workers, use_ray, address, progress, max_retries)
    finally:
        lock.close()


def _generate(out, config, cfg, state, workers, use_ray, address, progress, max_retries) -> dict:
    # Leftovers of killed workers (this directory's run holds the lock): never published, safe to remove.
    for d in (state / "tmp").iterdir():
        shutil.rmtree(d, ignore_errors=True)
    done_marker = state / "done.json"
    t0 = time.perf_counter()
    if done_marker.exists():
        summary = json.loads(done_marker.read_text())
        summary["already_complete"] = True
        return summary
    n = config.episodes
    published = _published(state, n)
    todo = [i for i in range(n) if i not in published]
    results: dict[int, dict] = {}
    bar = _Bar(n, len(published)) if progress else None
    ok = [
        sum(
            json.loads((state / "episodes" / episode_name(i) / "episode.json").read_text())["success"]
            for i in published
        )
    ]
    count = [len(published)]

    def on_done(r: dict) -> None:
        results[r["index"]] = r
        count[0] += 1
        ok[0] += int(r["success"])
        if bar is not None:
            bar.update(count[0], ok[0])

    if todo:
        nw = workers or os.cpu_count() or 1
        if use_ray:
            _run_ray(cfg, str(out), todo, address, workers, on_done, max_retries)
        else:
            _run_local(cfg, str(out), todo, min(nw, len(todo)), on_done, max_retries)
    gen_s = time.perf_counter() - t0
    if len(_published(state, n)) != n:
        missing = sorted(set(range(n)) - _published(state, n))
        raise FerrobotError(f"episodes {missing[:10]} were not published; re-run the same command to resume")
    summary = finalize(out, config)
    new = [r for r in results.values() if not r.get("cached")]
    frames = sum(r["length"] for r in new)
    summary.update(
        {
            "episodes_run_now": len(new),
            "resumed_from": len(published),
            "generation_wall_s": gen_s,
            "episodes_per_hour": 3600.0 * len(new) / gen_s if new and gen_s > 0 else None,
            "median_episode_wall_s": float(np.median([r["wall_s"] for r in new])) if new else None,
            "recorded_frames_per_s": frames / gen_s if new and gen_s > 0 else None,
            "executor": "ray" if use_ray else f"local process pool ({workers or os.cpu_count()} workers)",
            "total_wall_s": time.perf_counter() - t0,
        }
    )
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    tmp = state / "done.json.tmp"
    tmp.write_text(json.dumps(summary, indent=2))
    os.replace(tmp, done_marker)
    # The dataset is complete: the staged copies and what killed workers left are no longer needed.
    shutil.rmtree(state / "work", ignore_errors=True)
    for d in (state / "tmp").iterdir():
        shutil.rmtree(d, ignore_errors=True)
    for d in (state / "episodes").iterdir():
        shutil.rmtree(d, ignore_errors=True)
    return summary


def finalize(out: Path, config: GenerateConfig) -> dict:
    """Builds the dataset's files from the published episodes (from scratch, so a run killed here finalises
    again next time). Returns the dataset part of the summary."""
    from .hdf5 import finalize_hdf5
    from .lerobot import finalize_lerobot

    state = out / STATE_DIR
    dirs = [state / "episodes" / episode_name(i) for i in range(config.episodes)]
    metas = [json.loads((d / "episode.json").read_text()) for d in dirs]
    work = state / "work"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir()
    features = _features(config)
    info = {
        "fps": config.control_hz,
        "robot_type": robot_type(config.robot),
        "features": features,
        "ferrobot": config.to_dict(),
    }
    if config.format == "lerobot":
        finalize_lerobot(out, dirs, info, work, fault=lambda: _fault("finalize"))
    else:
        finalize_hdf5(out, dirs, info, work, fault=lambda: _fault("finalize"))
    ok = sum(m["success"] for m in metas)
    fails: dict[str, int] = {}
    for m in metas:
        if not m["success"]:
            fails[m["failed_stage"]] = fails.get(m["failed_stage"], 0) + 1
    return {
        "episodes": len(metas),
        "successes": ok,
        "success_rate": ok / len(metas),
        "failures_by_stage": fails,
        "frames": sum(m["length"] for m in metas),
        "format": config.format,
        "seed": config.seed,
    }


def robot_type(robot: str) -> str:
    """LeRobot's ``robot_type`` of a ``--robot`` value: the bundled name, or the URDF file's stem."""
    return robot if robot in ROBOTS else Path(robot).stem


def _features(config: GenerateConfig) -> dict:
    """The dataset features of ``config`` (:func:`ferrobot.control.features`, the shared contract)."""
    from ..control import features

    model, _ = resolve_robot(config.to_dict())
    cams = {c["name"]: (c["width"], c["height"]) for c in config.cameras}
    return features(model, None, cams, segmentation=config.segmentation)
