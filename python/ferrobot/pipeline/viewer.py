"""An interactive 3D view of an episode in one self-contained HTML file (no network, no dependencies):
the robot as its collision spheres, the table and objects, the chosen grasp, and the executed motion
played back. Drag to orbit, wheel to zoom, slider and play/pause for time.

Drawn with a small canvas-2D renderer (painter's algorithm over shaded spheres, box and cylinder
faces, and lines), so it opens in any browser offline.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from .scene import ROBOT_MOUNT

__all__ = ["viewer_data", "write_viewer"]


def _round(a, nd: int = 4):
    return np.round(np.asarray(a, dtype=np.float64), nd).tolist()


def viewer_data(pp) -> dict:
    """What the viewer draws, from a :class:`~ferrobot.pipeline.PickPlace` that ran with recorded frames."""
    model = pp.model
    spheres = pp.planner.sphere_model
    links, local = [], []
    for li, name in enumerate(model.link_names):
        s = spheres.spheres(name)
        for c in s:
            links.append(li)
            local.append(c)
    local = np.asarray(local).reshape(-1, 4)
    base = pp.base
    frames = []
    for st in pp.rec.states:
        poses = base @ model.fk_all(st["q"])  # (L, 4, 4) in the world
        centres = np.einsum("nij,nj->ni", poses[links], np.c_[local[:, :3], np.ones(len(local))])[:, :3]
        frames.append(
            {
                "t": round(st["t"], 3),
                "stage": st["stage"],
                "spheres": _round(centres),
                "objects": {k: _round(v[:3, :].ravel()) for k, v in st["objects"].items()},
            }
        )
    objects = []
    for name, kind, size, color in pp.scene_shapes():
        base_layer = name in ("table", ROBOT_MOUNT)
        objects.append({"name": name, "kind": kind, "size": _round(size), "color": list(color), "base": base_layer})
    grasp = None
    if getattr(pp, "choice", None) is not None:
        grasp = _round(pp.grasps_world[pp.choice : pp.choice + 1].gripper_lines()[0])
    return {
        "radii": _round(local[:, 3]),
        "frames": frames,
        "objects": objects,
        "grasp": grasp,
        "place": list(pp.spec.place_xy),
    }


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
