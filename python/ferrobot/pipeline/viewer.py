"""An interactive 3D view of an episode in one self-contained HTML file (no network, no dependencies):
the robot drawn with its visual geometry (meshes and primitives; collision spheres on request), the table
and objects, the grasps, the cameras' frustums, and the executed motion played back. Drag to orbit, wheel
to zoom, slider and play/pause for time.

Drawn with a small canvas-2D renderer (triangles shaded by a fixed light, back faces culled, depth-sorted by
the painter's algorithm, plus lines), so it opens in any browser offline.

The view: an orbit camera at azimuth ``az``, elevation ``el`` and distance ``dist`` around ``target`` (world
frame, z up): eye ``= target + dist (cos el cos az, cos el sin az, sin el)``, forward ``f`` towards the
target, right ``r = normalize(f x z)``, up ``u = r x f``. A world point ``p`` lands on the canvas (``width`` x
``height`` pixels) at ``(width / 2 + F (p - eye).r / z, height / 2 - F (p - eye).u / z)`` with
``z = (p - eye).f`` and the focal length ``F`` in pixels: :func:`project` in Python. The page's URL fragment
``#frame=K&paused=1&embed=1`` opens at frame ``K``, paused, with the canvas alone at the page's top-left.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from .. import _core
from .._tessellate import primitive_mesh
from .scene import ROBOT_MOUNT, TABLE_TOP

__all__ = ["DEFAULT_VIEW", "mesh_of", "project", "robot_meshes", "scene_data", "viewer_data", "write_viewer"]

#: The viewer's initial camera (see the module docstring) and canvas size.
DEFAULT_VIEW = {"az": -0.9, "el": 0.5, "dist": 1.7, "target": [0.42, 0.0, 0.6], "F": 700.0, "width": 900, "height": 620}

#: Colour of robot links without an URDF colour.
ROBOT_COLOR = (0.78, 0.80, 0.86)


def project(points, view: dict | None = None) -> np.ndarray:
    """Canvas pixel coordinates (N, 2) and depths (N,) as (N, 3) of world points (N, 3) under ``view``."""
    v = {**DEFAULT_VIEW, **(view or {})}
    az, el, dist, t = v["az"], v["el"], v["dist"], np.asarray(v["target"], dtype=np.float64)
    eye = t + dist * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    f = (t - eye) / np.linalg.norm(t - eye)
    r = np.cross(f, [0.0, 0.0, 1.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    d = np.asarray(points, dtype=np.float64).reshape(-1, 3) - eye
    z = d @ f
    return np.stack([v["width"] / 2 + v["F"] * (d @ r) / z, v["height"] / 2 - v["F"] * (d @ u) / z, z], axis=1)


#: Segments round the axis of a drawn sphere, cylinder or capsule (``_tessellate.primitive_mesh``).
VIEW_SEGMENTS = 20


def _decimate(verts: np.ndarray, faces: np.ndarray, max_faces: int):
    """Vertex clustering on a grid, coarsened until at most ``max_faces`` triangles remain."""
    if len(faces) <= max_faces:
        return verts, faces
    extent = float(np.ptp(verts, axis=0).max()) or 1.0
    cell = extent / 64
    while True:
        key = np.floor((verts - verts.min(0)) / cell).astype(np.int64)
        _, inv = np.unique(key, axis=0, return_inverse=True)
        inv = inv.ravel()
        f = inv[faces]
        f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
        if len(f) <= max_faces:
            n = inv.max() + 1
            v = np.zeros((n, 3))
            np.add.at(v, inv, verts)
            v /= np.bincount(inv, minlength=n)[:, None]
            return v, f
        cell *= 1.5


def mesh_of(geom: dict, max_faces: int = 1500) -> tuple[np.ndarray, np.ndarray]:
    """Triangle mesh (vertices in the geometry's parent frame, faces) of one geometry dict as
    ``RobotModel.visual_geometry`` / ``collision_geometry`` give it."""
    kind = geom["type"]
    if kind in ("box", "sphere", "cylinder", "capsule"):
        v, f = primitive_mesh(geom, VIEW_SEGMENTS)
    elif kind == "mesh":
        scaled = np.asarray(geom["vertices"]) * np.asarray(geom.get("scale", (1.0, 1.0, 1.0)))
        v, f = _decimate(scaled, np.asarray(geom["faces"]), max_faces)
    else:
        raise ValueError(f"unknown geometry type {kind!r}")
    o = np.asarray(geom["origin"])
    return v @ o[:3, :3].T + o[:3, 3], np.asarray(f, dtype=np.int64)


def robot_meshes(model, max_faces_per_link: int = 3000) -> list[dict]:
    """Per link with geometry: ``link`` (index in ``link_names``), ``V`` (n, 3) vertices in the link frame, ``F``
    (m, 3) faces and ``c`` the colour. Visual geometry, or the collision geometry of links without any."""
    out = []
    for li, name in enumerate(model.link_names):
        geoms = model.visual_geometry(name) or model.collision_geometry(name)
        if not geoms:
            continue
        vs, fs, n, color = [], [], 0, None
        per = max(200, max_faces_per_link // len(geoms))
        for g in geoms:
            v, f = mesh_of(g, per)
            vs.append(v)
            fs.append(f + n)
            n += len(v)
            if color is None and g.get("rgba") is not None:
                color = list(g["rgba"][:3])
        out.append({"link": li, "V": np.vstack(vs), "F": np.vstack(fs), "c": color or list(ROBOT_COLOR)})
    return out


def _round(a, nd: int = 4):
    return np.round(np.asarray(a, dtype=np.float64), nd).tolist()


def _object_mesh(kind: str, size) -> tuple[np.ndarray, np.ndarray]:
    """A scene object's mesh from its ``kind`` and ``size`` (box extents; radius; radius and length)."""
    size = [float(x) for x in size]
    if kind == "box":
        return primitive_mesh({"type": "box", "size": size})
    if kind == "sphere":
        return primitive_mesh({"type": "sphere", "radius": size[0]}, VIEW_SEGMENTS)
    if kind in ("cylinder", "capsule"):
        return primitive_mesh({"type": kind, "radius": size[0], "length": size[1]}, VIEW_SEGMENTS)
    raise ValueError(f"unknown object kind {kind!r}")


def scene_data(
    model,
    qs,
    *,
    base=None,
    times=None,
    stages=None,
    objects=(),
    object_poses=None,
    grasp_lines=None,
    cameras=(),
    spheres=None,
    place=None,
    view=None,
) -> dict:
    """What the viewer draws, for any robot and trajectory.

    ``qs`` (T, num_dof) joint positions (``dof_names`` order), ``base`` the robot's 4x4 world pose,
    ``times`` (T,) and ``stages`` (T,) labels; ``objects`` dicts with ``name``, ``kind`` (box, sphere,
    cylinder, capsule, mesh), ``size`` (box extents; radius; radius and length) or ``vertices`` / ``faces``,
    ``color`` and optionally ``base`` (drawn under everything); ``object_poses`` (T,) dicts name -> 4x4
    (default: identity); ``grasp_lines`` (N, 2, 3) segments (e.g. ``GraspGroup.gripper_lines()`` flattened);
    ``cameras`` dicts with ``pose`` (4x4, OpenCV frame), ``fx``, ``fy``, ``cx``, ``cy``, ``width``, ``height``;
    ``spheres`` a SphereModel drawn on request; ``view`` overrides :data:`DEFAULT_VIEW`.
    """
    qs = np.atleast_2d(np.asarray(qs, dtype=np.float64))
    base = np.eye(4) if base is None else np.asarray(base, dtype=np.float64)
    meshes = robot_meshes(model)
    link_ix = [m["link"] for m in meshes]
    s_links, s_local = [], np.zeros((0, 4))
    if spheres is not None:
        rows = []
        for li, name in enumerate(model.link_names):
            for c in spheres.spheres(name):
                s_links.append(li)
                rows.append(c)
        s_local = np.asarray(rows).reshape(-1, 4)
    frames = []
    for k, q in enumerate(qs):
        poses = base @ model.fk_all(q)
        fr = {
            "t": round(float(times[k]) if times is not None else float(k), 3),
            "stage": stages[k] if stages is not None else "",
            "links": [_round(poses[i][:3, :].ravel(), 5) for i in link_ix],
            "objects": {},
        }
        if len(s_links):
            c = np.einsum("nij,nj->ni", poses[s_links], np.c_[s_local[:, :3], np.ones(len(s_local))])[:, :3]
            fr["spheres"] = _round(c)
        else:
            fr["spheres"] = []
        ops = object_poses[k] if object_poses is not None else {}
        for o in objects:
            m = np.asarray(ops.get(o["name"], np.eye(4)))
            fr["objects"][o["name"]] = _round(m[:3, :].ravel())
        frames.append(fr)
    objs = []
    for o in objects:
        if o["kind"] == "mesh":
            v, f = _decimate(np.asarray(o["vertices"], dtype=np.float64), np.asarray(o["faces"]), 2000)
        else:
            v, f = _object_mesh(o["kind"], o["size"])
        objs.append(
            {
                "name": o["name"],
                "kind": o["kind"],
                "size": _round(o.get("size", [])),
                "color": list(o["color"]),
                "base": bool(o.get("base", False)),
                "V": _round(v),
                "F": np.asarray(f).tolist(),
            }
        )
    cams = []
    for c in cameras:
        cams.append({k: (_round(v) if k == "pose" else float(v)) for k, v in c.items()})
    return {
        "view": {**DEFAULT_VIEW, **(view or {})},
        "robot": [{"V": _round(m["V"], 5), "F": m["F"].tolist(), "c": m["c"]} for m in meshes],
        "radii": _round(s_local[:, 3]),
        "frames": frames,
        "objects": objs,
        "grasp": None if grasp_lines is None else _round(np.asarray(grasp_lines).reshape(-1, 2, 3)),
        "cameras": cams,
        "place": None if place is None else list(place),
    }


def viewer_data(episode) -> dict:
    """What the viewer draws, from an episode record (:class:`~ferrobot.pipeline.Episode`, ``result.episode``)
    of a :class:`~ferrobot.pipeline.PickPlace` run with recorded frames. The sphere model is the planner's,
    recorded in the episode (``episode.spheres``). Passing the ``PickPlace`` itself is deprecated."""
    from .pick_place import PickPlace

    if isinstance(episode, PickPlace):
        import warnings

        warnings.warn(
            "viewer_data(pp) is deprecated: pass the episode record, viewer_data(result.episode)",
            DeprecationWarning,
            stacklevel=2,
        )
        episode = episode.episode
    ep = episode
    states = ep.recorder.states
    objects = [
        {"name": name, "kind": kind, "size": size, "color": color, "base": name in ("table", ROBOT_MOUNT)}
        for name, kind, size, color in ep.scene_shapes()
    ]
    for o in objects:
        if o["kind"] == "mesh":  # mesh objects (clutter scenes): their scaled file mesh
            spec = ep.spec.object(o["name"])
            info = _core.load_mesh(spec.mesh, spec.scale)
            o["vertices"], o["faces"] = info.vertices, info.faces
    if getattr(ep.spec, "bin", None) is not None:
        from .clutter import BinSpec

        b = ep.spec.bin if isinstance(ep.spec.bin, BinSpec) else BinSpec(**ep.spec.bin)
        for name, size, _pose in b.walls(TABLE_TOP):
            objects.append({"name": name, "kind": "box", "size": size, "color": (0.45, 0.47, 0.52), "base": True})
    grasp = None
    if ep.choice is not None:
        grasp = gripper_lines(ep.grasps_world[ep.choice : ep.choice + 1], getattr(ep, "gripper", None))[0]
    cameras = []
    if ep.camera is not None:
        k = ep.camera.intrinsic_matrix
        cameras.append(
            {
                "pose": ep.camera.world_transform,
                "fx": k[0, 0],
                "fy": k[1, 1],
                "cx": k[0, 2],
                "cy": k[1, 2],
                "width": ep.camera.width,
                "height": ep.camera.height,
            }
        )
    return scene_data(
        ep.model,
        [st["q"] for st in states],
        base=ep.base,
        times=[st["t"] for st in states],
        stages=[st["stage"] for st in states],
        objects=objects,
        object_poses=[st["objects"] for st in states],
        grasp_lines=grasp,
        cameras=cameras,
        spheres=ep.spheres,
        place=ep.spec.place_xy,
    )


def gripper_lines(grasps, gripper=None) -> np.ndarray:
    """(N, 36, 2, 3) outline segments of ``grasps`` (a :class:`~ferrobot.grasp.GraspGroup`) drawn with
    ``gripper``'s finger geometry (a :class:`ferrobot.Gripper`: its detector finger depth and width, e.g. the
    2F-85's longer, wider pads); None: ``GraspGroup.gripper_lines``' defaults (the Panda hand's)."""
    if gripper is None:
        return grasps.gripper_lines()
    o = gripper.detection_options()
    return grasps.gripper_lines(finger_depth=o.finger_depth, finger_width=o.finger_width)


#: The page: HTML, CSS and the canvas renderer, with __TITLE__ and __DATA__ to fill in.
_TEMPLATE = Path(__file__).with_name("viewer_template.html")


def write_viewer(path, data: dict, title: str) -> Path:
    """Writes the interactive viewer page for ``data`` (from :func:`viewer_data`)."""
    page = (
        _TEMPLATE.read_text()
        .replace("__TITLE__", html.escape(title))
        .replace("__DATA__", json.dumps(data, separators=(",", ":")))
    )
    path = Path(path)
    path.write_text(page)
    return path
