"""Independent measurement of a sphere model against a robot's collision geometry (issue 17: the
automatic spheres must stick out at most 1 cm and cover the links), shared by
tests/test_sphere_fit.py and benches/sphere_fit.py.

Nothing here calls the spherizer's own measurement. Geometry is read from the URDF's description
(`RobotModel.collision_geometry`: primitive sizes and origins; mesh files are read again with
trimesh). Distances:

- primitives (box, sphere, cylinder, capsule): exact signed distance functions (numpy);
- meshes: unsigned distance to the nearest of a dense set of surface points (the vertices of the
  mesh subdivided until every edge is at most `h`, so every surface point is within h / sqrt(3) of
  one: the distance is over-estimated by at most that, never under-estimated), inside/outside by
  the outward normals of the 8 nearest surface points (majority vote; normals made consistent by
  trimesh per connected piece).

The distance to the link is the minimum over its elements. Protrusion is measured on Fibonacci
points of every sphere's surface (`spacing` apart) that lie outside the link and not inside another
sphere of the link (on the boundary of the spheres' union); coverage on random area-weighted
surface points of every element that are not inside another element.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from scipy.spatial import cKDTree


def _to_local(p: np.ndarray, origin: np.ndarray) -> np.ndarray:
    return (p - origin[:3, 3]) @ origin[:3, :3]


def _box_sd(q: np.ndarray, half: np.ndarray) -> np.ndarray:
    d = np.abs(q) - half
    return np.linalg.norm(np.maximum(d, 0.0), axis=1) + np.minimum(d.max(axis=1), 0.0)


def _cyl_sd(q: np.ndarray, r: float, hh: float) -> np.ndarray:
    d = np.stack([np.hypot(q[:, 0], q[:, 1]) - r, np.abs(q[:, 2]) - hh], axis=1)
    return np.linalg.norm(np.maximum(d, 0.0), axis=1) + np.minimum(d.max(axis=1), 0.0)


def _capsule_sd(q: np.ndarray, r: float, hh: float) -> np.ndarray:
    z = np.clip(q[:, 2], -hh, hh)
    return np.linalg.norm(q - np.stack([0 * z, 0 * z, z], axis=1), axis=1) - r


class _Element:
    """One collision element of a link, in the link frame."""

    def __init__(self, g: dict, h: float) -> None:
        self.kind = g["type"]
        self.origin = np.asarray(g["origin"], dtype=float)
        if self.kind == "mesh":
            mesh = trimesh.load(g["path"], force="mesh", process=True)
            mesh.apply_scale(1.0)
            v = np.asarray(mesh.vertices, dtype=float) * np.asarray(g["scale"], dtype=float)
            mesh = trimesh.Trimesh(v @ self.origin[:3, :3].T + self.origin[:3, 3], mesh.faces, process=True)
            mesh.fix_normals(multibody=True)
            self.mesh = mesh
            verts, faces = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=h)
            sub = trimesh.Trimesh(verts, faces, process=False)
            # Normals of the subdivided triangles are those of their parents; per vertex, the
            # area-weighted mean of its triangles' normals.
            self.points = np.asarray(sub.vertices)
            self.normals = np.asarray(sub.vertex_normals)
            self.tree = cKDTree(self.points)
            self.area = float(mesh.area)
            self.h = h
        elif self.kind == "box":
            self.half = np.asarray(g["size"], dtype=float) / 2
            s = self.half
            self.area = 8 * (s[0] * s[1] + s[1] * s[2] + s[0] * s[2])
        elif self.kind == "sphere":
            self.r = float(g["radius"])
            self.area = 4 * np.pi * self.r**2
        elif self.kind in ("cylinder", "capsule"):
            self.r = float(g["radius"])
            self.hh = float(g["length"]) / 2
            if self.kind == "cylinder":
                self.area = 2 * np.pi * self.r * 2 * self.hh + 2 * np.pi * self.r**2
            else:
                self.area = 2 * np.pi * self.r * 2 * self.hh + 4 * np.pi * self.r**2
        else:
            raise ValueError(f"unsupported collision element {self.kind}")

    def sd(self, p: np.ndarray) -> np.ndarray:
        """Signed distance (negative inside) of link-frame points; for meshes an upper bound of the
        distance outside (by at most h / sqrt(3))."""
        if self.kind == "mesh":
            d, idx = self.tree.query(p, k=8)
            nearest = d[:, 0]
            # Majority of the nearest surface points see p on their outer side.
            side = np.einsum("nkj,nkj->nk", p[:, None, :] - self.points[idx], self.normals[idx])
            outside = (side > 0).sum(axis=1) >= 4
            return np.where(outside, nearest, -nearest)
        q = _to_local(p, self.origin)
        if self.kind == "box":
            return _box_sd(q, self.half)
        if self.kind == "sphere":
            return np.linalg.norm(q, axis=1) - self.r
        if self.kind == "cylinder":
            return _cyl_sd(q, self.r, self.hh)
        return _capsule_sd(q, self.r, self.hh)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """n random area-weighted points of the element's surface (link frame)."""
        if self.kind == "mesh":
            pts, _ = trimesh.sample.sample_surface(self.mesh, n, seed=int(rng.integers(1 << 31)))
            return np.asarray(pts)
        if self.kind == "box":
            s = self.half
            faces = np.array([s[1] * s[2], s[1] * s[2], s[0] * s[2], s[0] * s[2], s[0] * s[1], s[0] * s[1]])
            f = rng.choice(6, size=n, p=faces / faces.sum())
            q = rng.uniform(-1, 1, size=(n, 3)) * s
            axis = f // 2
            q[np.arange(n), axis] = np.where(f % 2 == 0, -1.0, 1.0) * s[axis]
        elif self.kind == "sphere":
            u = rng.normal(size=(n, 3))
            q = self.r * u / np.linalg.norm(u, axis=1, keepdims=True)
        else:
            r, hh = self.r, self.hh
            side = 2 * np.pi * r * 2 * hh
            ends = 2 * np.pi * r**2 if self.kind == "cylinder" else 4 * np.pi * r**2
            on_side = rng.uniform(size=n) < side / (side + ends)
            t = rng.uniform(0, 2 * np.pi, size=n)
            q = np.stack([r * np.cos(t), r * np.sin(t), rng.uniform(-hh, hh, size=n)], axis=1)
            m = ~on_side
            if self.kind == "cylinder":
                rad = r * np.sqrt(rng.uniform(size=m.sum()))
                q[m, 0] = rad * np.cos(t[m])
                q[m, 1] = rad * np.sin(t[m])
                q[m, 2] = np.where(rng.uniform(size=m.sum()) < 0.5, -hh, hh)
            else:
                u = rng.normal(size=(m.sum(), 3))
                u = r * u / np.linalg.norm(u, axis=1, keepdims=True)
                u[:, 2] += np.where(u[:, 2] < 0, -hh, hh)
                q[m] = u
        return q @ self.origin[:3, :3].T + self.origin[:3, 3]


@dataclass
class LinkFit:
    link: str
    spheres: int
    max_protrusion: float  # m, on the union's boundary
    max_protrusion_any: float  # m, over every sphere's whole surface (buried parts included)
    coverage: float  # fraction of surface samples within `tol` of a sphere
    worst_gap: float  # m, largest distance of a surface sample outside every sphere


def _fibonacci(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    rho = np.sqrt(np.maximum(0.0, 1 - z * z))
    t = np.pi * (3 - np.sqrt(5)) * i
    return np.stack([rho * np.cos(t), rho * np.sin(t), z], axis=1)


def measure_link(
    link: str,
    geoms: list[dict],
    spheres: np.ndarray,
    *,
    spacing: float = 0.002,
    samples: int = 20_000,
    tol: float = 1e-3,
    h: float = 0.0015,
    seed: int = 0,
) -> LinkFit:
    """Protrusion and coverage of `spheres` ((k, 4) centre, radius; link frame) on a link whose
    collision elements are `geoms` (`RobotModel.collision_geometry(link)`)."""
    elements = [_Element(g, h) for g in geoms]
    spheres = np.asarray(spheres, dtype=float).reshape(-1, 4)
    c, r = spheres[:, :3], spheres[:, 3]

    def link_sd(p: np.ndarray) -> np.ndarray:
        return np.min([e.sd(p) for e in elements], axis=0)

    worst, worst_any = 0.0, 0.0
    for j in range(len(spheres)):
        n = int(np.clip(4 * np.pi * r[j] ** 2 / spacing**2, 64, 4000))
        p = c[j] + r[j] * _fibonacci(n)
        d = link_sd(p)
        worst_any = max(worst_any, float(d.max()))
        near = np.linalg.norm(c - c[j], axis=1) < r + r[j]
        near[j] = False
        others = np.flatnonzero(near)
        buried = (np.linalg.norm(p[:, None, :] - c[None, others], axis=2) < r[None, others] - 1e-9).any(axis=1)
        if (~buried).any():
            worst = max(worst, float(d[~buried].max()))
    rng = np.random.default_rng(seed)
    area = np.array([e.area for e in elements])
    counts = rng.multinomial(samples, area / area.sum())
    pts = []
    for k, (e, m) in enumerate(zip(elements, counts, strict=True)):
        if m == 0:
            continue
        q = e.sample(int(m), rng)
        if len(elements) > 1:
            # Not on the link's surface if deeper than 1 mm inside another element.
            inside = np.zeros(len(q), bool)
            for o, other in enumerate(elements):
                if o != k:
                    inside |= other.sd(q) < -1e-3
            q = q[~inside]
        pts.append(q)
    pts = np.concatenate(pts) if pts else np.zeros((0, 3))
    if len(pts) and len(spheres):
        gap = np.full(len(pts), np.inf)
        for j in range(len(spheres)):
            gap = np.minimum(gap, np.linalg.norm(pts - c[j], axis=1) - r[j])
        coverage = float(np.mean(gap <= tol))
        worst_gap = float(max(gap.max(), 0.0))
    else:
        coverage, worst_gap = (1.0, 0.0) if not len(pts) else (0.0, np.inf)
    return LinkFit(link, len(spheres), max(worst, 0.0), max(worst_any, 0.0), coverage, worst_gap)


def measure_model(model, sphere_model, **kw) -> list[LinkFit]:
    """Every link with collision geometry of `model` against `sphere_model` (a `SphereModel`)."""
    out = []
    for link in model.link_names:
        geoms = model.collision_geometry(link)
        if not geoms:
            continue
        out.append(measure_link(link, geoms, np.asarray(sphere_model.spheres(link)), **kw))
    return out
