"""A held-out object set for ``benches/grasp_eval.py``: procedurally generated objects unlike the
development set (pybullet_data's random_urdfs, which are lumpy convex-ish blobs).

    python benches/heldout_objects.py OUT_DIR [--per-kind N] [--seed S]

Writes, per object, ``NAME_K.obj`` per convex part K (parts touch but do not overlap, so the
union's volume and centre of mass are the sums over the parts) and ``NAME.urdf`` with one
``<collision>`` per part (mass = density x volume, density 400-1,200 kg/m^3, lateral friction
0.6-1.0). Kinds, ``--per-kind`` each
(dimensions drawn uniformly from the ranges in the code, fixed ``--seed``):

- ``rod``: a 12-sided prism, radius 4-8 mm, 10-20 cm long, lying flat (slender, curved);
- ``hammer``: a square handle 1.2-1.8 cm thick, 12-18 cm long, with a head 2.2-3.2 cm square and
  4.5-6 cm long across one end (heavy at one end: the centre of mass is off the handle's middle);
- ``lshape``: two bars 6-12 cm long, 1.5-3 cm wide, 2-4 cm tall meeting at a right angle (concave);
- ``mug``: a 16-segment wall (outer radius 3-4 cm, 7-10 cm tall, 4-6 mm thick), a 5 mm bottom and
  a three-bar handle (concave, open top);
- ``bowl``: a 16-segment flared wall (rim radius 5-7 cm, 3-5 cm tall, 4 mm thick) and a bottom;
- ``small``: a box 1-2.2 cm on each side;
- ``ring``: a 16-segment torus-like ring (radius 2.5-3.5 cm, square section 0.8-1.4 cm): a hole
  in the middle (concave, curved);
- ``ladle``: a handle 0.8-1.2 cm square, 12-16 cm long, and a small open cup (radius 2.5-3 cm)
  at one end (concave and heavy at one end).

The evaluation scales objects whose middle bounding-box extent exceeds 6.5 cm down (the Panda hand
opens 8 cm), and simulates multi-part objects by convex decomposition in ferrobot and by the exact
parts in PyBullet (see its docstring).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

KINDS = ("rod", "hammer", "lshape", "mug", "bowl", "small", "ring", "ladle")


def box(lo, hi) -> np.ndarray:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def prism(radius: float, length: float, sides: int = 12) -> np.ndarray:
    """A regular prism along x, centred at the origin."""
    a = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    ring = np.stack([np.cos(a) * radius, np.sin(a) * radius], axis=1)
    return np.concatenate([np.c_[np.full(sides, -length / 2), ring], np.c_[np.full(sides, length / 2), ring]])


def wall(r_in_lo, r_out_lo, r_in_hi, r_out_hi, z0, z1, segments=16) -> list[np.ndarray]:
    """A ring of convex wall segments between z0 and z1 (radii may flare)."""
    parts = []
    for k in range(segments):
        a0, a1 = 2 * np.pi * k / segments, 2 * np.pi * (k + 1) / segments
        pts = []
        for a in (a0, a1):
            c, s = np.cos(a), np.sin(a)
            for r, z in ((r_in_lo, z0), (r_out_lo, z0), (r_in_hi, z1), (r_out_hi, z1)):
                pts.append([r * c, r * s, z])
        parts.append(np.array(pts))
    return parts


def disc(radius, z0, z1, sides=16) -> np.ndarray:
    a = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    ring = np.stack([np.cos(a) * radius, np.sin(a) * radius], axis=1)
    return np.concatenate([np.c_[ring, np.full(sides, z0)], np.c_[ring, np.full(sides, z1)]])


def make(kind: str, rng: np.random.Generator) -> list[np.ndarray]:
    u = rng.uniform
    if kind == "rod":
        r, length = u(0.004, 0.008), u(0.10, 0.20)
        return [prism(r, length)]
    if kind == "hammer":
        t, length = u(0.012, 0.018), u(0.12, 0.18)
        hw, hl = u(0.022, 0.032), u(0.045, 0.06)
        handle = box([-length / 2, -t / 2, 0], [length / 2 - hw, t / 2, t])
        head = box([length / 2 - hw, -hl / 2, 0], [length / 2, hl / 2, hw])
        return [handle, head]
    if kind == "lshape":
        a, b, w, h = u(0.06, 0.12), u(0.06, 0.12), u(0.015, 0.03), u(0.02, 0.04)
        return [box([0, 0, 0], [a, w, h]), box([0, w, 0], [w, b, h])]
    if kind == "mug":
        ro, h, t = u(0.03, 0.04), u(0.07, 0.10), u(0.004, 0.006)
        parts = wall(ro - t, ro, ro - t, ro, 0.005, h)
        parts.append(disc(ro, 0.0, 0.005))
        hz0, hz1, reach, ht = 0.25 * h, 0.8 * h, u(0.02, 0.03), 0.008
        parts.append(box([ro, -ht / 2, hz0], [ro + reach, ht / 2, hz0 + ht]))
        parts.append(box([ro, -ht / 2, hz1 - ht], [ro + reach, ht / 2, hz1]))
        parts.append(box([ro + reach, -ht / 2, hz0], [ro + reach + ht, ht / 2, hz1]))
        return parts
    if kind == "bowl":
        rr, h, t = u(0.05, 0.07), u(0.03, 0.05), 0.004
        rb = 0.55 * rr
        parts = wall(rb - t, rb, rr - t, rr, 0.004, h)
        parts.append(disc(rb, 0.0, 0.004))
        return parts
    if kind == "small":
        return [box([0, 0, 0], u(0.01, 0.022, size=3))]
    if kind == "ring":
        r, s = u(0.025, 0.035), u(0.008, 0.014)
        return wall(r - s / 2, r + s / 2, r - s / 2, r + s / 2, 0.0, s)
    if kind == "ladle":
        t, length, rc = u(0.008, 0.012), u(0.12, 0.16), u(0.025, 0.03)
        parts = [box([rc, -t / 2, 0.0], [rc + length, t / 2, t])]
        parts += wall(rc - 0.004, rc, rc - 0.004, rc, 0.004, 0.03)
        parts.append(disc(rc, 0.0, 0.004))
        return parts
    raise ValueError(kind)


def hull_volume(pts: np.ndarray) -> float:
    from scipy.spatial import ConvexHull

    return float(ConvexHull(pts).volume)


def write_obj(path: Path, pts: np.ndarray) -> None:
    """A convex part as an OBJ of its hull, faces wound outwards."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(pts)
    idx = {int(v): i for i, v in enumerate(hull.vertices)}
    inner = pts[hull.vertices].mean(axis=0)
    lines = [f"v {p[0]:.6f} {p[1]:.6f} {p[2]:.6f}" for p in pts[hull.vertices]]
    for tri in hull.simplices:
        a, b, c = pts[tri]
        if np.dot(np.cross(b - a, c - a), a - inner) < 0:
            tri = tri[[0, 2, 1]]
        lines.append("f " + " ".join(str(1 + idx[int(v)]) for v in tri))
    path.write_text("\n".join(lines) + "\n")


URDF = """<?xml version="1.0"?>
<robot name="{name}">
  <link name="base">
    <contact><lateral_friction value="{friction:.3f}"/></contact>
    <inertial><mass value="{mass:.5f}"/><inertia ixx="1e-5" iyy="1e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial>
{collisions}
  </link>
</robot>
"""


def generate(out: Path, per_kind: int = 12, seed: int = 18) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    paths = []
    for kind in KINDS:
        for i in range(per_kind):
            paths.append(write_object(out, f"{kind}_{i:02d}", make(kind, rng), rng))
    return paths


def write_object(out: Path, name: str, parts, rng: np.random.Generator) -> Path:
    """Writes ``parts`` (convex point sets) as ``NAME_K.obj`` meshes and a multi-part ``NAME.urdf`` in ``out``
    with a density drawn in 400-1200 kg/m^3 and a friction in 0.6-1.0 (in that order from ``rng``)."""
    collisions = []
    for k, part in enumerate(parts):
        write_obj(out / f"{name}_{k}.obj", part)
        collisions.append(f'    <collision><geometry><mesh filename="{name}_{k}.obj"/></geometry></collision>')
    mass = sum(hull_volume(p) for p in parts) * rng.uniform(400.0, 1200.0)
    friction = rng.uniform(0.6, 1.0)
    path = out / f"{name}.urdf"
    path.write_text(URDF.format(name=name, mass=mass, friction=friction, collisions="\n".join(collisions)))
    return path


def generator_main(generate_fn, doc: str, per_kind: int, seed: int) -> int:
    """The command line of an object-set generator: ``OUT [--per-kind N] [--seed S]``, ``generate_fn(out,
    per_kind, seed)`` returning the written paths (shared by this script and ``thin_objects.py``)."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path)
    ap.add_argument("--per-kind", type=int, default=per_kind)
    ap.add_argument("--seed", type=int, default=seed)
    args = ap.parse_args()
    paths = generate_fn(args.out, args.per_kind, args.seed)
    print(f"{len(paths)} objects in {args.out}")
    return 0


def main() -> int:
    return generator_main(generate, __doc__, per_kind=12, seed=18)


if __name__ == "__main__":
    sys.exit(main())
