"""An exact contact judge independent of ferrobot's geometry code: coal (hpp-fcl) on the URDF's collision elements.

The URDF is parsed here with the standard library (``<collision>``: origin, box, sphere, cylinder, capsule, mesh
with scale; meshes as their convex hulls, built by coal's qhull from trimesh-loaded vertices, as ferrobot's own
judge does); only the link poses come from ferrobot (``RobotModel.fk``, checked against Pinocchio elsewhere).
Used by ``benches/reactive.py`` and ``tests/test_reactive.py``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np


def _rpy(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _floats(text: str | None, default: str) -> list[float]:
    return [float(x) for x in (text or default).split()]


def _ball(geom, T: np.ndarray, vertices: np.ndarray | None) -> list[float]:
    """A ball (x, y, z, r; link frame) holding one collision element."""
    if vertices is not None:
        c = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
        r = float(np.linalg.norm(vertices - c, axis=1).max())
    else:
        c = np.zeros(3)
        if geom.tag == "box":
            r = 0.5 * float(np.linalg.norm(_floats(geom.get("size"), "")))
        elif geom.tag == "sphere":
            r = float(geom.get("radius"))
        elif geom.tag == "cylinder":
            r = float(np.hypot(float(geom.get("radius")), 0.5 * float(geom.get("length"))))
        else:  # capsule
            r = float(geom.get("radius")) + 0.5 * float(geom.get("length"))
    return [*(T[:3, :3] @ c + T[:3, 3]), r]


class CoalJudge:
    """Link collision geometry of a URDF as coal shapes; distances between link pairs and to obstacles."""

    def __init__(self, model, urdf_text: str, mesh_dir: Path | None = None):
        import coal
        import trimesh

        self.coal, self.model = coal, model
        self.links: dict[str, list[tuple[object, np.ndarray]]] = {}
        self.balls: dict[str, tuple[np.ndarray, float]] = {}
        root = ET.fromstring(urdf_text)
        for link in root.findall("link"):
            parts = []
            for col in link.findall("collision"):
                o = col.find("origin")
                T = np.eye(4)
                if o is not None:
                    T[:3, :3] = _rpy(*_floats(o.get("rpy"), "0 0 0"))
                    T[:3, 3] = _floats(o.get("xyz"), "0 0 0")
                g = col.find("geometry")
                shape = None
                for child in g:
                    if child.tag == "box":
                        shape = coal.Box(*_floats(child.get("size"), ""))
                    elif child.tag == "sphere":
                        shape = coal.Sphere(float(child.get("radius")))
                    elif child.tag == "cylinder":
                        shape = coal.Cylinder(float(child.get("radius")), float(child.get("length")))
                    elif child.tag == "capsule":
                        shape = coal.Capsule(float(child.get("radius")), float(child.get("length")))
                    elif child.tag == "mesh":
                        name = child.get("filename")
                        for prefix in ("package://", "file://"):
                            name = name.removeprefix(prefix)
                        path = Path(name)
                        if not path.is_absolute() and mesh_dir is not None:
                            path = mesh_dir / name.removeprefix("meshes/")
                        v = np.asarray(trimesh.load(str(path), force="mesh").vertices, dtype=float)
                        v = v * np.array(_floats(child.get("scale"), "1 1 1"))
                        pts = coal.StdVec_Vec3s()
                        for p in v:
                            pts.append(p)
                        shape = coal.Convex.convexHull(pts, False, "")
                if shape is not None:
                    parts.append((shape, T, _ball(child, T, v if child.tag == "mesh" else None)))
            if parts:
                self.links[link.get("name")] = [(s, T) for s, T, _ in parts]
                # Broad phase: a ball holding the link's parts (link frame), from the URDF's numbers.
                balls = np.array([b for _, _, b in parts])
                c = balls[:, :3].mean(axis=0)
                r = float((np.linalg.norm(balls[:, :3] - c, axis=1) + balls[:, 3]).max())
                self.balls[link.get("name")] = (c, r)
        self._req = coal.DistanceRequest()
        self._req.enable_signed_distance = True

    def _tf(self, T: np.ndarray):
        return self.coal.Transform3s(np.ascontiguousarray(T[:3, :3]), np.ascontiguousarray(T[:3, 3]))

    def _posed(self, q, link: str):
        base = self.model.fk(q, link)
        return [(s, self._tf(base @ T)) for s, T in self.links[link]]

    def _dist(self, a, b) -> float:
        best = np.inf
        for sa, ta in a:
            for sb, tb in b:
                res = self.coal.DistanceResult()
                best = min(best, float(self.coal.distance(sa, ta, sb, tb, self._req, res)))
        return best

    def pair_distances(self, q, pairs) -> dict[tuple[str, str], float]:
        """Signed distance (m, negative = penetration) of each (link, link) pair with geometry at ``q``; for pairs
        whose bounding balls are more than 2 cm apart, the gap between the balls (a lower bound: they cannot touch)."""
        cache: dict[str, list] = {}

        def posed(link):
            if link not in cache:
                cache[link] = self._posed(q, link)
            return cache[link]

        poses: dict[str, np.ndarray] = {}

        def ball_gap(a, b):
            for x in (a, b):
                if x not in poses:
                    poses[x] = self.model.fk(q, x)
            (ca, ra), (cb, rb) = self.balls[a], self.balls[b]
            pa = poses[a][:3, :3] @ ca + poses[a][:3, 3]
            pb = poses[b][:3, :3] @ cb + poses[b][:3, 3]
            return float(np.linalg.norm(pa - pb)) - ra - rb

        out = {}
        for a, b in pairs:
            if a not in self.links or b not in self.links:
                continue
            gap = ball_gap(a, b)
            # Balls more than 2 cm apart: the links are at least that far apart (a lower bound, no contact).
            out[(a, b)] = gap if gap > 0.02 else self._dist(posed(a), posed(b))
        return out

    def obstacle_distance(self, q, obstacles) -> tuple[float, str | None]:
        """Smallest signed distance between any link and the obstacles: a list of (kind, size, position) with kind
        ``sphere`` (size = radius) or ``box`` (size = half extent, axis-aligned); also the closest link. Links whose
        bounding ball is more than 2 cm from every obstacle's count with the gap between the balls (a lower bound)."""
        shapes = []
        for kind, size, p in obstacles:
            s = self.coal.Sphere(size) if kind == "sphere" else self.coal.Box(2 * size, 2 * size, 2 * size)
            T = np.eye(4)
            T[:3, 3] = p
            shapes.append((s, self._tf(T)))
        best, where = np.inf, None
        for link in self.links:
            T = self.model.fk(q, link)
            c, r = self.balls[link]
            pc = T[:3, :3] @ c + T[:3, 3]
            # Broad phase: the gap between the link's ball and each obstacle's ball is a lower bound.
            gap = min(
                float(np.linalg.norm(pc - np.asarray(p))) - r - (size if kind == "sphere" else np.sqrt(3) * size)
                for kind, size, p in obstacles
            )
            if gap > 0.02:
                d = gap
            else:
                d = self._dist([(s, self._tf(T @ L)) for s, L in self.links[link]], shapes)
            if d < best:
                best, where = d, link
        return best, where
