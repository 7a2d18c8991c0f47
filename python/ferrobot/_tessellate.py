"""Closed triangle meshes of the primitive shapes, the one tessellation used wherever a primitive becomes
triangles (the object-file reader's generated OBJs, the HTML viewer).

Geometry dicts as :meth:`ferrobot.RobotModel.collision_geometry` gives them, in the shape's own frame: box
``size`` (full extents); sphere ``radius``; cylinder and capsule ``radius`` and ``length`` along z (the
capsule's length between its ball centres). Every mesh is closed with its triangles wound counter-clockwise
seen from outside (outward normals, positive signed volume). Boxes are exact; round shapes are inscribed
polyhedra whose vertices lie on the true surface, with ``segments`` round the axis and latitude steps of the
same angle on round ends: a cylinder's sides lie at most ``1 - cos(pi / segments)`` of the radius inside it,
a round end's faces about twice that (0.25 % at :data:`ROUND_SEGMENTS`).
"""

from __future__ import annotations

import math

import numpy as np

from .errors import InvalidArgumentError

#: Segments round the axis for simulation-grade meshes: faces within 0.25 % of the radius of the surface.
ROUND_SEGMENTS = 64

#: The 12 triangles (outward) of a box whose corner ``c`` is at (x, y, z) = (c & 1, c >> 1 & 1, c >> 2 & 1)
#: of its extents (0: the low side, 1: the high side).
BOX_FACES = np.array(
    [[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
     [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]],
    dtype=np.int64,
)  # fmt: skip


def box_mesh(size) -> tuple[np.ndarray, np.ndarray]:
    """The 8 corners and 12 outward triangles of a box of full extents ``size`` centred at the origin."""
    h = 0.5 * np.asarray(size, dtype=np.float64)
    c = np.arange(8)
    signs = np.stack([c & 1, c >> 1 & 1, c >> 2 & 1], axis=1) * 2.0 - 1.0
    return signs * h, BOX_FACES.copy()


def revolve(profile: list[tuple[float, float]], segments: int = ROUND_SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """A closed surface of revolution about z: ``profile`` is (z, r) from the bottom pole (r = 0) to the top
    pole (r = 0), z increasing; triangles wound counter-clockwise seen from outside."""
    a = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    ring = np.c_[np.cos(a), np.sin(a)]
    rings = profile[1:-1]
    verts = [np.array([[0.0, 0.0, profile[0][0]]])]
    verts += [np.c_[r * ring, np.full(segments, z)] for z, r in rings]
    verts.append(np.array([[0.0, 0.0, profile[-1][0]]]))
    v = np.vstack(verts)
    top = len(v) - 1
    j = np.arange(segments)
    k = (j + 1) % segments
    tris = [np.c_[np.zeros(segments, dtype=np.int64), 1 + k, 1 + j]]
    for i in range(len(rings) - 1):
        lo, hi = 1 + i * segments, 1 + (i + 1) * segments
        tris += [np.c_[lo + j, lo + k, hi + k], np.c_[lo + j, hi + k, hi + j]]
    last = 1 + (len(rings) - 1) * segments
    tris.append(np.c_[np.full(segments, top), last + j, last + k])
    return v, np.vstack(tris).astype(np.int64)


def primitive_mesh(g: dict, segments: int = ROUND_SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (N, 3) and outward faces (M, 3) of the primitive ``g`` (box, sphere, cylinder, capsule; see
    the module docstring) in its own frame; ``segments`` (4 or more, a multiple of 4) round the axis."""
    if segments < 4 or segments % 4:
        raise InvalidArgumentError(f"segments must be a multiple of 4 and at least 4, got {segments}")
    t = g["type"]
    if t == "box":
        return box_mesh(g["size"])
    if t not in ("sphere", "cylinder", "capsule"):
        raise InvalidArgumentError(f"geometry type '{t}' is not a box, sphere, cylinder or capsule")
    r = float(g["radius"])
    polar = np.linspace(0.0, 0.5 * np.pi, segments // 4 + 1)
    if t == "sphere":
        return revolve([(-r * math.cos(p), r * math.sin(p)) for p in np.r_[polar, np.pi - polar[-2::-1]]], segments)
    h = 0.5 * float(g["length"])
    if t == "cylinder":
        return revolve([(-h, 0.0), (-h, r), (h, r), (h, 0.0)], segments)
    bottom = [(-h - r * math.cos(p), r * math.sin(p)) for p in polar]
    return revolve(bottom + [(-z, rr) for z, rr in bottom[::-1]], segments)
