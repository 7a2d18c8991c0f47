"""A set of thin and flat objects for ``benches/grasp_eval.py``: rings, bent tubes, plates, washers and flat bars
lying flat, 0.5-2 cm tall (objects the detector found hard: the table stops deep hands, and rings have a hole).

    python benches/thin_objects.py OUT_DIR [--per-kind N] [--seed S]

Writes, like ``benches/heldout_objects.py`` (whose writer it uses), one ``NAME_K.obj`` per convex part and
``NAME.urdf`` with one ``<collision>`` per part (mass = density x volume, density 400-1,200 kg/m^3, lateral
friction 0.6-1.0). Every size stays under the evaluation's 6.5 cm middle extent, so nothing is scaled down.
Kinds, ``--per-kind`` each (dimensions drawn uniformly from the ranges in the code, fixed ``--seed``):

- ``flatring``: a 16-segment ring of square-ish section: mid radius 2-2.6 cm, wall 0.8-1.4 cm wide,
  1.0-2.0 cm tall (a hole in the middle: closing across one side of the wall, a finger in the hole);
- ``torus``: a 16-segment torus of round (10-sided) section: mid radius 2-2.5 cm, tube radius 6-9 mm
  (1.2-1.8 cm tall, curved rims);
- ``benttube``: a round (10-sided) tube of radius 7-9 mm bent along an arc of radius 4-7 cm over 60-140 deg,
  lying flat, in 10 segments (1.4-1.8 cm tall, curved and slender);
- ``plate``: a box 0.8-1.5 cm thick, 4-6.5 cm by 7-12 cm (too flat for deep fingers);
- ``washer``: a 16-segment flat annulus 0.5-0.9 cm thick, outer radius 2-3 cm, hole radius 0.8-1.4 cm;
- ``flatbar``: a box 1.0-1.5 cm thick, 2-3 cm wide, 10-15 cm long.

Not used to tune anything: the detector's changes for thin objects were chosen from the diagnosis of why
no grasp was found (see BENCHMARKS.md, "Thin and flat objects"); this set measures them.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from heldout_objects import box, generator_main, wall, write_object  # noqa: E402

KINDS = ("flatring", "torus", "benttube", "plate", "washer", "flatbar")


def tube_segments(
    centre_radius: float, tube_radius: float, a0: float, a1: float, segments: int, sides: int = 10
) -> list[np.ndarray]:
    """Convex segments of a round tube (``sides``-gon section) bent along an arc in the xy plane, resting on
    z = 0 (section centre at z = tube_radius), from angle ``a0`` to ``a1``."""
    ph = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    parts = []
    for k in range(segments):
        pts = []
        for a in (a0 + (a1 - a0) * k / segments, a0 + (a1 - a0) * (k + 1) / segments):
            rad = centre_radius + tube_radius * np.cos(ph)
            z = tube_radius + tube_radius * np.sin(ph)
            pts.append(np.stack([rad * np.cos(a), rad * np.sin(a), z], 1))
        parts.append(np.concatenate(pts))
    return parts


def make(kind: str, rng: np.random.Generator) -> list[np.ndarray]:
    u = rng.uniform
    if kind == "flatring":
        r, s, h = u(0.02, 0.026), u(0.008, 0.014), u(0.01, 0.02)
        return wall(r - s / 2, r + s / 2, r - s / 2, r + s / 2, 0.0, h)
    if kind == "torus":
        return tube_segments(u(0.02, 0.025), u(0.006, 0.009), 0.0, 2 * np.pi, 16)
    if kind == "benttube":
        big, ang = u(0.04, 0.07), np.radians(u(60, 140))
        return tube_segments(big, u(0.007, 0.009), -ang / 2, ang / 2, 10)
    if kind == "plate":
        t, a, b = u(0.008, 0.015), u(0.04, 0.065), u(0.07, 0.12)
        return [box([0, 0, 0], [b, a, t])]
    if kind == "washer":
        ro, ri, t = u(0.02, 0.03), u(0.008, 0.014), u(0.005, 0.009)
        return wall(ri, ro, ri, ro, 0.0, t)
    if kind == "flatbar":
        t, w, length = u(0.01, 0.015), u(0.02, 0.03), u(0.10, 0.15)
        return [box([0, 0, 0], [length, w, t])]
    raise ValueError(kind)


def generate(out: Path, per_kind: int = 6, seed: int = 7) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    paths = []
    for kind in KINDS:
        for i in range(per_kind):
            paths.append(write_object(out, f"{kind}_{i:02d}", make(kind, rng), rng))
    return paths


def main() -> int:
    return generator_main(generate, __doc__, per_kind=6, seed=7)


if __name__ == "__main__":
    sys.exit(main())
