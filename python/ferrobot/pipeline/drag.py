"""Dragging an object away from a bin wall with a fingertip pressed on its top: the primitive for flat pieces lying
against a wall or in a corner, where the hand's housing meets the wall at every grasp, no finger fits between
object and wall for a push, and a slide along the wall leaves them as ungraspable (the middle of a 24 cm-wide bin
is the only place the 20.8 cm housing fits across a 6.5 cm plate).

The closed fingers come down onto the object's top, press it down with a force N (a soft drive: its stiffness
times how far the target lies below the top), and move horizontally away from the wall, taking the object with
them. The fingertip holds the object while the horizontal force H satisfies H <= mu_fo N, and the object slides
on the floor once H > mu_of (N + m g): possible exactly when mu_fo / mu_of > 1 + m g / N. With friction
coefficients combined by averaging (Rapier's default, ferrobot's simulator), fingers at 1.0, objects at 0.7-1.0
and a bin of one material at 0.6 (walls and floor): mu_fo = (1 + mu_o) / 2 and mu_of = (mu_o + 0.6) / 2, a ratio
of 1.25-1.31, so N > 4 m g suffices (about 12 N for a 0.3 kg piece). On a floor of the finger's friction (1.0)
the ratio is 1 and no force drags the object (PyBullet's product rule agrees: mu_o against mu_o; MuJoCo's
maximum rule gives 1.0 against mu_o, a drag only for objects below 1.0).

:func:`plan_drag` works on the observations :func:`ferrobot.pipeline.push.plan_push` uses (a
:class:`~ferrobot.pipeline.push.Heightmap` of the labelled cloud, the camera's
:class:`~ferrobot.pipeline.push.FreeSpace`). For each of ``num_directions`` horizontal directions d whose motion
leaves the object more clearance (its footprint's distance to anything else observed 1 cm or more above the support:
walls, neighbours) or more room for the housing (along the best of 8 axes through its centre, the free length on the
nearer side, up to ``housing_room``) by at least ``min_gain``, and whose moved footprint stays clear of all of it,
it tries contact points over the object's whole top (at least ``min_support`` of the closed fingertips' footprint on
the target's observed cells, a quarter of it within ``flatness`` of the top there, nothing else as high under them,
and the press where it does not stand the object up on its leading edge: see below), nearest the footprint's centre
first, with the closing axis across or along d and the hand upright or leaning its top towards d by each of
``tilts``. The motion: down the approach (5 cm) to ``clearance`` above the top, the hand's solids (closed
fingers, palm, housing) clear of everything observed, the target's columns included; the press (the hand is checked
resting on the top: the object stops it); the drag along d by the distance (the hand clear of everything but the
target); and back up the approach by 10 cm. Among the feasible drags, the one leaving the most room for the housing
plus half the clearance (up to 10 cm) wins, then the one pressing nearest the centre, the least tilted, the
shortest. Nothing is simulated here: the plan is hand poses (world frame) for an executor.

*Tipping.* Pulled along d by its top, a piece turns about its leading bottom edge unless the press and its weight
hold it down (:func:`tipping_line`): the press must act at least mu h behind that edge (h the top's height there, mu
the object-floor friction, ``tip_friction``); then no press force tips it, whatever its unknown mass. An upright
hand meets the top with the fingertips' flat face, whose trailing edge can carry the press; a leaning hand meets it
with the fingertips' leading edge (the lowest) alone. Measured in ferrobot's simulator
(``tests/test_wall_moves.py``): a 6.5 cm plate dragged by a hand leaning 0.4 rad pressing at its leading edge stands
up on that edge; upright at the same place, or leaning 2.25 cm further back, it slides flat. Pieces whose centre
lies in front of the line (a tube dragged across its axis: its support is a line under the centre; a 5 x 5 x 6.3 cm
block: its centre 2.5 cm behind the edge, mu h 5 cm) turn under any drag, wherever pressed: a tube rolls the drag's
way (measured: 6-16 cm out of corners), a block topples forward; their contacts are not restricted. A low, flat
piece 3 mm from both walls of a corner has no drag: the only fingertip placements whose housing clears both walls
lean about 0.5 rad over a wall and press at its leading edge, in front of the line (the corner is where the housing
rules out every grasp as well; corner18h in BENCHMARKS.md); 3 cm from both walls, upright drags over the whole top
reach slabs.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidArgumentError
from .push import FreeSpace, Heightmap, _checked_motion, _collides, _hand_samples, hand_rotation
from .slide import _descent_collides

__all__ = ["DragPlan", "plan_drag", "drag_feasible", "tipping_line"]


@dataclass
class DragPlan:
    """A planned drag: the hand-link poses (4x4, world) above the start (``pre``), at the start (the
    fingertips ``clearance`` above the object's top), pressed (moved down the approach until the fingertips
    are ``press`` below the top: the drive's target, which the object stops), and at the end of the drag; the
    drag direction (unit, world, horizontal), the object's intended displacement ``distance`` (m), the press
    depth (m), the fingertip (TCP) start point (world), the object's top height at the contact (m above the
    support), the hand's tilt (rad), the clearance the object is left (m) and the plan's score."""

    target: int
    pre: np.ndarray
    start: np.ndarray
    pressed: np.ndarray
    end: np.ndarray
    direction: np.ndarray
    distance: float
    press: float
    tip_start: np.ndarray
    top: float
    tilt: float
    clearance_after: float
    score: float


def drag_feasible(mu_finger: float, mu_object: float, mu_floor: float, mass: float, press_force: float) -> bool:
    """Whether a fingertip pressing an object down with ``press_force`` (N) can drag it over the floor, with
    friction coefficients combined by averaging (ferrobot's simulator): the largest horizontal force the
    fingertip transmits, mu_fo N, exceeds the floor's resistance mu_of (N + m g). Coefficients in [0, 10],
    ``mass`` in (0, 100] kg, ``press_force`` in (0, 1000] N."""
    for name, v in (("mu_finger", mu_finger), ("mu_object", mu_object), ("mu_floor", mu_floor)):
        if not 0.0 <= v <= 10.0:
            raise InvalidArgumentError(f"{name}: {v} is outside [0, 10]")
    if not 0.0 < mass <= 100.0:
        raise InvalidArgumentError(f"mass: {mass} kg is outside (0, 100]")
    if not 0.0 < press_force <= 1000.0:
        raise InvalidArgumentError(f"press_force: {press_force} N is outside (0, 1000]")
    mu_fo = 0.5 * (mu_finger + mu_object)
    mu_of = 0.5 * (mu_object + mu_floor)
    return mu_fo * press_force > mu_of * (press_force + 9.81 * mass)


def tipping_line(lead: float, height: float, mu_floor: float) -> float:
    """How far along the drag (m, the coordinate ``lead`` is in) the pressing fingertip may reach without tipping
    the object forward whatever it presses with: ``lead`` - ``mu_floor`` x ``height``.

    The object rests on the floor; the fingertip touches its top at height h, pressing down with N and pulling
    along the drag with H; the floor resists with friction mu (N + m g) at the base. Moments about the base's
    leading edge (the footprint's extreme along the drag, ``lead``): H h tips it forward, the press N at e_p
    behind the edge and the weight m g at e_g behind it hold it down. While it slides, H = mu (N + m g), so it
    stays down when mu (N + m g) h <= N e_p + m g e_g, i.e. N (mu h - e_p) <= m g (e_g - mu h). With e_p and e_g
    both at least mu h this holds for every N: the press can be as hard as the drag needs (N > mu m g / (mu_fo -
    mu), ``drag_feasible``) without knowing the mass. With e_p < mu h it holds only for N below
    m g (e_g - mu h) / (mu h - e_p), which needs the object's mass (a camera does not see it) and, for a contact
    near the leading edge, is below the drag's lower bound: a plate pressed 5 mm from its leading edge (mu 0.7,
    h 2 cm, e_g 3.25 cm) stays down only for N < 2 m g, slides only for N > 3.5 m g. ``mu_floor`` is the object-
    floor coefficient as the contact combines it (the largest the objects may have)."""
    return float(lead) - float(mu_floor) * float(height)


def plan_drag(
    points,
    labels,
    target: int,
    gripper,
    support_z: float,
    bounds,
    *,
    cell: float = 0.005,
    num_directions: int = 16,
    distances=(0.12, 0.10, 0.08, 0.06, 0.04),
    tilts=(0.0, 0.2, 0.4, 0.5),
    press: float = 0.015,
    inset: float = 0.002,
    flatness: float = 0.01,
    min_support: float = 0.5,
    max_contacts: int = 64,
    tip_friction: float = 0.8,
    margin: float = 0.004,
    clearance: float = 0.005,
    min_gain: float = 0.02,
    housing_room: float = 0.12,
    unknown_height: float = 1.0,
    heightmap: Heightmap | None = None,
    view: FreeSpace | None = None,
) -> DragPlan | None:
    """The best drag of the object labelled ``target`` (see the module's docstring), or None. Arguments as
    :func:`ferrobot.pipeline.push.plan_push`'s; ``press`` (m): how far below the object's top the fingertips' target
    goes (the pressing force is the drive's stiffness times it); the closed fingertips' footprint (shrunk by
    ``inset``, m) must have at least ``min_support`` of its area over the object's observed cells, the object's top
    there level within ``flatness`` (m), and nothing else as high under it; ``max_contacts``: contact points tried
    per direction and hand orientation (1 cm apart: 64 cover a 8 x 8 cm top); ``tip_friction``: the largest object-
    floor friction coefficient (as the contact combines it) the tipping check assumes. Ranges:
    ``num_directions`` 1-64, ``distances`` in (0, 0.3] m, ``tilts`` in
    [0, 1.2] rad, ``press`` in (0, 0.04] m, ``inset`` in [0, 0.005] m, ``min_support`` in (0, 1], ``flatness`` in
    [0, 0.03] m, ``max_contacts`` 1-64, ``margin`` and ``clearance`` in [0, 0.02] m, ``min_gain`` in [0, 0.2] m,
    ``housing_room`` in [0.02, 0.3] m, ``tip_friction`` in [0, 2]."""
    for name, v in (("num_directions", num_directions), ("max_contacts", max_contacts)):
        if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or not 1 <= v <= 64:
            raise InvalidArgumentError(f"{name}: expected an integer in [1, 64], got {v!r}")
    distances, _ = _checked_motion(distances, tilts, (0.01,), margin, clearance)
    if not 0.0 < press <= 0.04:
        raise InvalidArgumentError(f"press: {press} m is outside (0, 0.04]")
    if not 0.0 <= inset <= 0.005:
        raise InvalidArgumentError(f"inset: {inset} m is outside [0, 0.005]")
    if not 0.0 <= flatness <= 0.03:
        raise InvalidArgumentError(f"flatness: {flatness} m is outside [0, 0.03]")
    if not 0.0 < min_support <= 1.0:
        raise InvalidArgumentError(f"min_support: {min_support} is outside (0, 1]")
    if not 0.0 <= min_gain <= 0.2:
        raise InvalidArgumentError(f"min_gain: {min_gain} m is outside [0, 0.2]")
    if not 0.02 <= housing_room <= 0.3:
        raise InvalidArgumentError(f"housing_room: {housing_room} m is outside [0.02, 0.3]")
    if not 0.0 <= tip_friction <= 2.0:
        raise InvalidArgumentError(f"tip_friction: {tip_friction} is outside [0, 2]")
    hm = heightmap or Heightmap.from_points(points, labels, support_z, bounds, cell)
    mine = hm.label == target
    if not mine.any():
        return None
    ii, jj = np.nonzero(mine)
    foot = hm.origin + (np.column_stack([ii, jj]) + 0.5) * hm.cell
    centre = foot.mean(axis=0)
    # Whatever stands 1 cm or more above the support, not the target (walls, neighbours; unobserved columns when
    # there is no camera view): the object is dragged away from it and must not be dragged into it.
    obstacle = ((hm.height >= 0.01) | ((hm.height < 0) & (view is None))) & ~mine
    oi, oj = np.nonzero(obstacle)
    obstacles = hm.origin + (np.column_stack([oi, oj]) + 0.5) * hm.cell

    def clearance_of(fp: np.ndarray) -> float:
        if len(obstacles) == 0:
            return 0.1
        c = fp.mean(axis=0)
        near = obstacles[np.all(np.abs(obstacles - c) < 0.25, axis=1)]
        if len(near) == 0:
            return 0.1
        d2 = ((fp[::2, None, :] - near[None, :, :]) ** 2).sum(axis=2)
        return min(0.1, float(np.sqrt(d2.min())))

    # Room for the hand's housing: along each of 8 horizontal axes through the footprint's centre, the free length
    # on both sides (the nearer obstacle of three rays, the middle one and two ``palm_height`` / 2 to its sides);
    # the best axis's smaller side. A grasp needs about half the housing's width (10.4 cm) on both sides.
    axes = np.array([[math.cos(math.pi * m / 8), math.sin(math.pi * m / 8)] for m in range(8)])
    rays = np.concatenate([axes, -axes])  # (16, 2)
    ray_steps = np.arange(hm.cell, housing_room + 1e-9, hm.cell)
    ph = gripper.fingers.palm_height / 2

    def room_of(fp: np.ndarray) -> float:
        c = fp.mean(axis=0)
        perp = np.column_stack([-rays[:, 1], rays[:, 0]])
        starts = c[None, None, :] + np.array([0.0, ph, -ph])[None, :, None] * perp[:, None, :]  # (16, 3, 2)
        pts = starts[:, :, None, :] + ray_steps[None, None, :, None] * rays[:, None, None, :]  # (16, 3, S, 2)
        i, j, inside = hm.cells(pts.reshape(-1, 2))
        hit = (~inside | obstacle[i, j]).reshape(len(rays), 3, len(ray_steps)).any(axis=1)  # (16, S)
        first = np.where(hit.any(axis=1), hit.argmax(axis=1), len(ray_steps))
        free = np.where(first > 0, ray_steps[np.maximum(first - 1, 0)], 0.0)
        free = np.where(first == len(ray_steps), housing_room, free)
        return float(np.minimum(free[:8], free[8:]).max())

    now_clear, now_room = clearance_of(foot), room_of(foot)
    f = gripper.fingers
    samples = _hand_samples(gripper, 0.008, margin)
    tcp = np.asarray(gripper.tcp, dtype=float)
    up = np.array([0.0, 0.0, 1.0])
    step = 0.008
    descent = np.arange(0.0, 0.0501, step)
    lift = np.arange(step, 0.1001, 2 * step)
    best: DragPlan | None = None
    for k in range(int(num_directions)):
        ang = 2 * math.pi * k / num_directions
        d = np.array([math.cos(ang), math.sin(ang), 0.0])
        # Distances whose moved footprint stays clear of every obstacle on the way and gains clearance.
        feasible = []
        for dist in distances:
            ok = True
            for s in (*np.arange(step, dist, step), dist):
                i, j, inside = hm.cells(foot + s * d[:2])
                if not inside.all() or obstacle[i, j].any():
                    ok = False
                    break
            if not ok:
                continue
            moved = foot + dist * d[:2]
            after, room = clearance_of(moved), room_of(moved)
            if after >= now_clear + min_gain or room >= now_room + min_gain:
                feasible.append((room + 0.5 * after, after, dist))
        if not feasible:
            continue
        # Most room for the housing (and clearance) first; of equal room the shortest drag.
        feasible.sort(key=lambda v: (-v[0], v[2]))
        # No plan of this direction scores above its best value (less the shortest drag's share): when that does
        # not beat the best plan so far, nothing here can (ties keep the earlier plan, as below).
        bound = feasible[0][0] - 0.01 * distances[-1]
        if best is not None and bound <= best.score:
            continue
        side = np.cross(up, d)
        # The tipping line (see ``tipping_line``): a contact whose fingertip footprint lies wholly behind it, with
        # the object's centre, tips the object forward under no press force; in front of it only a press below a
        # bound proportional to the object's unknown weight would not.
        lead = float((foot @ d[:2]).max())
        centre_along = float(centre @ d[:2])
        for across, tilt in itertools.product((True, False), tilts):
            # The closed fingertips' footprint: along the closing axis twice the finger thickness, across it the
            # fingers' height; closing across d puts the closing axis along ``side``.
            half_side = f.thickness if across else f.height / 2
            half_d = f.height / 2 if across else f.thickness
            contacts = []
            # Contact points 1 cm apart at least, nearest the footprint's centre first.
            for p in foot[np.argsort(((foot - centre) ** 2).sum(axis=1))]:
                if any(float(np.linalg.norm(p - q)) < 0.01 for q, _ in contacts):
                    continue
                g = np.stack(
                    np.meshgrid(
                        np.linspace(-half_d + inset, half_d - inset, 5),
                        np.linspace(-half_side + inset, half_side - inset, 5),
                        indexing="ij",
                    ),
                    axis=-1,
                ).reshape(-1, 2)
                under = p + g[:, :1] * d[:2] + g[:, 1:] * side[:2]
                i, j, inside = hm.cells(under)
                on = inside & (hm.label[i, j] == target)
                if on.mean() < min_support:
                    continue
                h = hm.height[i, j][on]
                # Nothing else under the fingertips as high as the object's top there (they would land on it).
                others = inside & ~on & (hm.height[i, j] > h.max() - 0.005)
                # A contact patch, not a peak: a quarter of the footprint within ``flatness`` of the top there.
                if others.any() or (h >= h.max() - flatness).sum() < 0.25 * len(on):
                    continue
                # Upright, the fingertips meet the top with a flat face, and the press can act anywhere in it: at
                # worst at its trailing edge. Leaning, their leading edge (along d, the lowest) meets it alone. A
                # piece whose centre lies behind the tipping line stays down under a press behind it too, but one in
                # front of it stands it up on its leading edge; a piece whose centre lies in front of the line
                # (round across d, or tall) turns under any drag, wherever it is pressed: it rolls or topples
                # forward, which moves it the drag's way.
                edge = float(p @ d[:2]) + (half_d if tilt > 0 else -half_d)
                line = tipping_line(lead, float(h.max()), tip_friction)
                if centre_along <= line < edge:
                    continue
                contacts.append((p, float(h.max())))
                if len(contacts) >= int(max_contacts):
                    break
            a = -math.cos(tilt) * up - math.sin(tilt) * d  # the hand's top leans towards d
            a = a / np.linalg.norm(a)
            c = side if across else d
            c = c - (c @ a) * a
            c = c / np.linalg.norm(c)
            rg = np.column_stack([a, c, np.cross(a, c)])
            body = samples @ rg.T
            for p, top in contacts:
                # Contacts come nearest the centre first: once one cannot beat the best plan, no later one can.
                if best is not None and bound - 0.5 * float(np.linalg.norm(p - centre)) - 0.01 * tilt <= best.score:
                    break
                # Resting on the top with the grown fingers clear of the support below it.
                if top - margin < 0.003:
                    continue
                tip = np.array([p[0], p[1], hm.support_z + top + clearance])
                # The target's own camera shadow counts as free, its columns as solid (2.5D).
                if any(_descent_collides(hm, body + tip - s * a, target, unknown_height, view) for s in descent):
                    continue
                rest = tip - np.array([0.0, 0.0, clearance - 0.001])
                if _collides(hm, body + rest, target, unknown_height, view):
                    continue
                for value, after, dist in feasible:
                    if any(
                        _collides(hm, body + rest + s * d, target, unknown_height, view)
                        for s in (*np.arange(step, dist, step), dist)
                    ):
                        continue
                    end_tip = rest + dist * d
                    if any(_descent_collides(hm, body + end_tip - s * a, target, unknown_height, view) for s in lift):
                        continue
                    off = float(np.linalg.norm(p - centre))
                    score = value - 0.5 * off - 0.01 * tilt - 0.01 * dist
                    if best is None or score > best.score:
                        rot = hand_rotation(gripper, a, c)
                        start = np.eye(4)
                        start[:3, :3] = rot
                        start[:3, 3] = tip - rot @ tcp
                        pre, pressed, end = start.copy(), start.copy(), start.copy()
                        pre[:3, 3] -= 0.05 * a
                        # Along the approach (the executor's soft axis), to ``press`` below the top.
                        pressed[:3, 3] += (clearance + press) / math.cos(tilt) * a
                        end[:3, 3] = pressed[:3, 3] + dist * d
                        best = DragPlan(
                            target, pre, start, pressed, end, d, dist, press, tip, top, float(tilt), after, score
                        )
                    break
                else:
                    continue
                break  # the nearest feasible contact to the centre for this orientation
    return best
