"""A live 3D view through viser (``pip install "ferrobot[viewer]"``): the same scene the HTML viewer draws
(:func:`ferrobot.pipeline.viewer.scene_data`), served to a browser at ``http://HOST:PORT`` with a frame slider
and play / pause. ``ferrobot view PATH`` opens a demo's output folder or a URDF file.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ..errors import InvalidArgumentError
from ..transforms import matrix_to_quat
from .viewer import scene_data

__all__ = ["LiveView", "episode_scene", "robot_scene"]


def _pose(m3x4) -> tuple[np.ndarray, np.ndarray]:
    """(wxyz, position) of a 3x4 pose from the page data, whose rotations are FK rotations rounded for the
    page: they are projected back onto the nearest rotation (polar decomposition) before conversion."""
    m = np.asarray(m3x4, dtype=np.float64).reshape(3, 4)
    u, _, vt = np.linalg.svd(m[:, :3])
    r = u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt
    return matrix_to_quat(r), m[:, 3].copy()


class LiveView:
    """A viser server showing ``data`` (from :func:`scene_data`): robot links and objects as meshes posed per
    frame, grasp lines, camera frustums. ``set_frame(k)`` poses everything as at frame ``k``."""

    def __init__(self, data: dict, host: str = "127.0.0.1", port: int = 8080):
        try:
            import viser
        except ImportError as e:
            raise ImportError('the live viewer needs viser: pip install "ferrobot[viewer]"') from e
        self.data = data
        self.server = viser.ViserServer(host=host, port=port)
        sc = self.server.scene
        self.links = [
            sc.add_mesh_simple(
                f"/robot/link_{i}",
                np.asarray(r["V"], dtype=np.float32),
                np.asarray(r["F"], dtype=np.uint32),
                color=tuple(float(c) for c in r["c"]),
            )
            for i, r in enumerate(data["robot"])
        ]
        self.objects = {
            o["name"]: sc.add_mesh_simple(
                f"/objects/{o['name']}",
                np.asarray(o["V"], dtype=np.float32),
                np.asarray(o["F"], dtype=np.uint32),
                color=tuple(float(c) for c in o["color"]),
            )
            for o in data["objects"]
        }
        self.grasp = None
        if data.get("grasp"):
            self.grasp = sc.add_line_segments(
                "/grasp", np.asarray(data["grasp"], dtype=np.float32), colors=(48, 224, 80)
            )
        self.cameras = []
        for i, c in enumerate(data.get("cameras", [])):
            wxyz, pos = _pose(np.asarray(c["pose"])[:3])
            self.cameras.append(
                sc.add_camera_frustum(
                    f"/cameras/{i}",
                    fov=float(2 * np.arctan2(c["height"] / 2, c["fy"])),
                    aspect=c["width"] / c["height"],
                    scale=0.12,
                    wxyz=wxyz,
                    position=pos,
                    color=(64, 192, 255),
                )
            )
        n = len(data["frames"])
        self.slider = self.server.gui.add_slider("frame", min=0, max=max(n - 1, 1), step=1, initial_value=0)
        self.playing = self.server.gui.add_checkbox("play", initial_value=True)
        self.slider.on_update(lambda _: self.set_frame(int(self.slider.value)))
        self.frame = -1
        self.set_frame(0)

    @property
    def port(self) -> int:
        return self.server.get_port()

    def set_frame(self, k: int) -> None:
        n = len(self.data["frames"])
        if not 0 <= k < n:
            raise InvalidArgumentError(f"frame: expected 0..{n - 1}, got {k}")
        fr = self.data["frames"][k]
        for h, m in zip(self.links, fr["links"], strict=True):
            h.wxyz, h.position = _pose(m)
        for name, h in self.objects.items():
            h.wxyz, h.position = _pose(fr["objects"][name])
        self.frame = k

    def run(self, fps: float = 15.0) -> None:
        """Plays the frames in a loop while ``play`` is ticked, until interrupted."""
        n = len(self.data["frames"])
        while True:
            if self.playing.value and n > 1:
                k = (self.frame + 1) % n
                self.slider.value = k
                self.set_frame(k)
            time.sleep(1.0 / fps)

    def close(self) -> None:
        self.server.stop()


def _subsample(n: int, max_frames: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, max_frames)).round().astype(int))


def episode_scene(folder, max_frames: int = 300) -> dict:
    """The scene of a ``ferrobot demo`` output folder (``report.json``, ``trajectory.npz``): the robot replaying
    its executed joint positions, the objects at their start poses (the trajectory file records the robot
    only; ``viewer.html`` in the folder has the objects moving), the camera and the chosen grasp."""
    from .. import _core, robots
    from ..grasp import GraspGroup
    from .scene import ROBOT_MOUNT, TABLE_SIZE, TABLE_TOP, ObjectSpec, SceneSpec, build_world

    folder = Path(folder)
    if not (folder / "report.json").is_file():
        raise InvalidArgumentError(f"path: {folder} has no report.json (not a ferrobot demo folder)")
    report = json.loads((folder / "report.json").read_text())
    sd = dict(report["scene"])
    sd["objects"] = [ObjectSpec(**o) for o in sd["objects"]]
    spec = SceneSpec(**sd)
    model = robots.panda()
    traj = folder / "trajectory.npz"
    if traj.is_file():  # the bundled robot whose joints the trajectory names (the Panda for older folders)
        with np.load(traj) as z:
            names = [str(n) for n in z["joint_names"]] if "joint_names" in z else None
        if names is not None and names != list(model.dof_names):
            other = robots.ur5e()
            if names != list(other.dof_names):
                raise InvalidArgumentError(
                    f"path: {folder} was recorded with a robot that is not bundled (joints {names}); "
                    "view its viewer.html instead"
                )
            model = other
    name = "panda" if model.dof_names[-1].startswith("panda") else "robot"
    world, robot, camera = build_world(spec, model, name=name)
    shapes = [("table", "box", None), (ROBOT_MOUNT, "box", None)] + [(o.name, o.kind, o) for o in spec.objects]
    objects, poses = [], {}

    for name, kind, o in shapes:
        if o is None:
            size = TABLE_SIZE if name == "table" else (0.3, 0.3, TABLE_TOP)
            color = (0.55, 0.42, 0.30) if name == "table" else (0.3, 0.3, 0.32)
            objects.append({"name": name, "kind": kind, "size": size, "color": color, "base": True})
        elif kind == "mesh":  # mesh objects (clutter scenes): their scaled file mesh
            info = _core.load_mesh(o.mesh, o.scale)
            objects.append(
                {
                    "name": name,
                    "kind": kind,
                    "size": o.size,
                    "color": o.color,
                    "vertices": info.vertices,
                    "faces": info.faces,
                }
            )
        else:
            objects.append({"name": name, "kind": kind, "size": o.size, "color": o.color})
        poses[name] = world.get_object_pose(name)
    if spec.bin is not None:
        from .clutter import BinSpec

        b = spec.bin if isinstance(spec.bin, BinSpec) else BinSpec(**spec.bin)
        for name, size, _pose in b.walls(TABLE_TOP):
            objects.append({"name": name, "kind": "box", "size": size, "color": (0.45, 0.47, 0.52), "base": True})
            poses[name] = world.get_object_pose(name)
    traj = folder / "trajectory.npz"
    if traj.is_file():
        with np.load(traj) as z:
            ix = _subsample(len(z["positions"]), max_frames)
            qs, times, stages = z["positions"][ix], z["times"][ix], [str(s) for s in z["stage"][ix]]
    else:
        qs, times, stages = robot.joint_positions[None], [0.0], ["scene"]
    grasp = None
    if "grasp" in report:
        g = report["grasp"]
        row = np.zeros(17)
        # The finger height the grasp was detected with (reports before it was stored: the Panda's 2 cm).
        row[:4] = [g["score"], g["width"], g.get("height", 0.02), g["depth"]]
        row[4:13] = np.asarray(g["rotation_world"]).ravel()
        row[13:16] = g["translation_world"]
        geo = report.get("gripper", {})  # the demo's gripper (older reports: the Panda hand's defaults)
        kw = {k: geo[k] for k in ("finger_depth", "finger_width") if k in geo}
        grasp = GraspGroup(row[None]).gripper_lines(**kw)[0]
    k = camera.intrinsic_matrix
    cams = [
        {
            "pose": camera.world_transform,
            "fx": k[0, 0],
            "fy": k[1, 1],
            "cx": k[0, 2],
            "cy": k[1, 2],
            "width": camera.width,
            "height": camera.height,
        }
    ]
    return scene_data(
        model,
        qs,
        base=robot.world_transform,
        times=times,
        stages=stages,
        objects=objects,
        object_poses=[poses] * len(qs),
        grasp_lines=grasp,
        cameras=cams,
        place=spec.place_xy,
    )


def robot_scene(urdf, trajectory=None, max_frames: int = 300, **model_kwargs) -> dict:
    """A URDF robot alone, at its neutral configuration or replaying ``trajectory`` (an ``.npz`` with
    ``positions`` (T, num_dof), or an array)."""
    from .._core import RobotModel

    model = RobotModel.from_urdf(urdf, **model_kwargs)
    if trajectory is None:
        qs = model.neutral_configuration()[None]
    elif isinstance(trajectory, (str, Path)):
        with np.load(trajectory) as z:
            qs = z["positions"]
    else:
        qs = np.asarray(trajectory, dtype=np.float64)
    qs = np.atleast_2d(qs)[_subsample(len(np.atleast_2d(qs)), max_frames)]
    pts = model.fk_all(qs[0])[:, :3, 3]
    centre = (pts.min(0) + pts.max(0)) / 2
    extent = float(np.ptp(pts, axis=0).max())
    return scene_data(model, qs, view={"target": centre.tolist(), "dist": max(0.5, 2.2 * extent)})
