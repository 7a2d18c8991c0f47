"""Writes a procedurally generated object set (OBJ files) for benchmarks on objects never used for tuning.

    python benches/make_objects.py DIR [--n N] [--seed S]

Kinds, drawn in turn with random sizes (metres): superellipsoids (from pillows and cubes to spindles),
bent tubes (slender and curved, capped), L-shapes (two overlapping boxes: concave), rings (tori: a hole),
and dumbbells (two balls on a bar: thin in the middle). Every mesh is closed and consistently oriented.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from ferrobot.grasp._group import _BOX_FACES


def _grid_surface(points: np.ndarray, close_u: bool) -> tuple[np.ndarray, np.ndarray]:
    """Triangles of a (nu, nv, 3) grid closed along v (and along u when ``close_u``)."""
    nu, nv, _ = points.shape
    idx = np.arange(nu * nv).reshape(nu, nv)
    faces = []
    for i in range(nu if close_u else nu - 1):
        i2 = (i + 1) % nu
        for j in range(nv):
            j2 = (j + 1) % nv
            a, b, c, d = idx[i, j], idx[i2, j], idx[i2, j2], idx[i, j2]
            faces += [[a, b, c], [a, c, d]]
    return points.reshape(-1, 3), np.array(faces)


def _cap(verts: np.ndarray, faces: np.ndarray, ring: np.ndarray, flip: bool) -> tuple[np.ndarray, np.ndarray]:
    c = len(verts)
    verts = np.vstack([verts, verts[ring].mean(axis=0)])
    new = [[c, ring[(k + 1) % len(ring)], ring[k]] for k in range(len(ring))]
    new = np.array(new)
    if flip:
        new = new[:, [0, 2, 1]]
    return verts, np.vstack([faces, new])


def superellipsoid(rng) -> tuple[np.ndarray, np.ndarray]:
    a = rng.uniform(0.012, 0.035, size=3)
    e1, e2 = rng.uniform(0.3, 1.4, size=2)
    nu, nv = 18, 24
    eta = np.linspace(-np.pi / 2, np.pi / 2, nu + 2)[1:-1]
    om = np.linspace(-np.pi, np.pi, nv, endpoint=False)
    Eg, Og = np.meshgrid(eta, om, indexing="ij")

    def f(x, e):
        return np.sign(x) * np.abs(x) ** e

    p = np.stack(
        [
            a[0] * f(np.cos(Eg), e1) * f(np.cos(Og), e2),
            a[1] * f(np.cos(Eg), e1) * f(np.sin(Og), e2),
            a[2] * f(np.sin(Eg), e1),
        ],
        -1,
    )
    v, t = _grid_surface(p, close_u=False)
    t = t[:, [0, 2, 1]]
    v = np.vstack([v, [0, 0, -a[2]], [0, 0, a[2]]])
    s, n = len(v) - 2, len(v) - 1
    bottom = [[s, (j + 1) % nv, j] for j in range(nv)]
    top = [[n, (nu - 1) * nv + j, (nu - 1) * nv + (j + 1) % nv] for j in range(nv)]
    return v, np.vstack([t, bottom, top])


def bent_tube(rng) -> tuple[np.ndarray, np.ndarray]:
    r = rng.uniform(0.008, 0.016)
    big = rng.uniform(0.05, 0.10)
    ang = rng.uniform(np.radians(50), np.radians(140))
    nu, nv = 24, 16
    th = np.linspace(-ang / 2, ang / 2, nu)
    ph = np.linspace(0, 2 * np.pi, nv, endpoint=False)
    T, P = np.meshgrid(th, ph, indexing="ij")
    rad = big + r * np.cos(P)
    p = np.stack([rad * np.cos(T), rad * np.sin(T), r * np.sin(P)], -1)
    v, f = _grid_surface(p, close_u=False)
    v, f = _cap(v, f, np.arange(nv), flip=True)
    v, f = _cap(v, f, np.arange((nu - 1) * nv, nu * nv), flip=False)
    v[:, 0] -= big
    return v, f


def _box(lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """An axis-aligned box from ``lo`` to ``hi``; corner c at bits (x, y, z) = (c & 1, c >> 1 & 1, c >> 2 & 1)."""
    v = np.array([[x, y, z] for z in (lo[2], hi[2]) for y in (lo[1], hi[1]) for x in (lo[0], hi[0])])
    return v, _BOX_FACES.copy()


def l_shape(rng) -> tuple[np.ndarray, np.ndarray]:
    t = rng.uniform(0.015, 0.03)
    la, lb = rng.uniform(0.05, 0.10), rng.uniform(0.04, 0.08)
    h = rng.uniform(0.015, 0.04)
    v1, f1 = _box([0, 0, 0], [la, t, h])
    v2, f2 = _box([0.0005, 0.0005, 0.0003], [t - 0.0005, lb, h - 0.0003])
    return np.vstack([v1, v2]), np.vstack([f1, f2 + len(v1)])


def ring(rng) -> tuple[np.ndarray, np.ndarray]:
    big, r = rng.uniform(0.025, 0.04), rng.uniform(0.006, 0.012)
    nu, nv = 32, 14
    th = np.linspace(0, 2 * np.pi, nu, endpoint=False)
    ph = np.linspace(0, 2 * np.pi, nv, endpoint=False)
    T, P = np.meshgrid(th, ph, indexing="ij")
    rad = big + r * np.cos(P)
    p = np.stack([rad * np.cos(T), rad * np.sin(T), r * np.sin(P)], -1)
    return _grid_surface(p, close_u=True)


def dumbbell(rng) -> tuple[np.ndarray, np.ndarray]:
    rb, rs, length = rng.uniform(0.006, 0.01), rng.uniform(0.015, 0.025), rng.uniform(0.06, 0.11)
    parts = []
    for x, rr in ((0.0, rs), (length, rs * rng.uniform(0.6, 1.0))):
        nu, nv = 12, 16
        eta = np.linspace(-np.pi / 2, np.pi / 2, nu + 2)[1:-1]
        om = np.linspace(-np.pi, np.pi, nv, endpoint=False)
        Eg, Og = np.meshgrid(eta, om, indexing="ij")
        p = np.stack([x + rr * np.cos(Eg) * np.cos(Og), rr * np.cos(Eg) * np.sin(Og), rr * np.sin(Eg)], -1)
        v, f = _grid_surface(p, close_u=False)
        f = f[:, [0, 2, 1]]
        v = np.vstack([v, [x, 0, -rr], [x, 0, rr]])
        s, n = len(v) - 2, len(v) - 1
        f = np.vstack(
            [
                f,
                [[s, (j + 1) % nv, j] for j in range(nv)],
                [[n, (nu - 1) * nv + j, (nu - 1) * nv + (j + 1) % nv] for j in range(nv)],
            ]
        )
        parts.append((v, f))
    nv = 12
    ph = np.linspace(0, 2 * np.pi, nv, endpoint=False)
    xs = np.linspace(0.0, length, 2)
    X, P = np.meshgrid(xs, ph, indexing="ij")
    p = np.stack([X, rb * np.cos(P), rb * np.sin(P)], -1)
    v, f = _grid_surface(p, close_u=False)
    v, f = _cap(v, f, np.arange(nv), flip=True)
    v, f = _cap(v, f, np.arange(nv, 2 * nv), flip=False)
    parts.append((v, f))
    verts, faces, off = [], [], 0
    for v, f in parts:
        verts.append(v)
        faces.append(f + off)
        off += len(v)
    v = np.vstack(verts)
    v[:, 0] -= length / 2
    return v, np.vstack(faces)


KINDS = [superellipsoid, bent_tube, l_shape, ring, dumbbell]


def write_obj(path: Path, v: np.ndarray, f: np.ndarray) -> None:
    lines = [f"v {x:.7f} {y:.7f} {z:.7f}" for x, y, z in v] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f]
    path.write_text("\n".join(lines) + "\n")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir", type=Path)
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--seed", type=int, default=12345)
    args = ap.parse_args()
    args.dir.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    for i in range(args.n):
        kind = KINDS[i % len(KINDS)]
        v, f = kind(rng)
        write_obj(args.dir / f"{i:03d}_{kind.__name__}.obj", v, f)
    print(f"wrote {args.n} objects to {args.dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
