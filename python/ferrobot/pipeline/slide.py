"""Sliding an object along a bin wall: the primitive for objects the hand can neither grasp where they lie nor
push off the wall (flat pieces within a few centimetres of a wall or in a corner, where no finger fits between
object and wall).

The closed fingers press the object's face that looks into the bin (the side away from the wall) towards the
wall and move along the wall: the finger-object contact (friction 1.0 at the fingers, 0.7-1.0 at the objects)
grips harder than the object-wall contact (0.6 at the walls), so the object slides along the wall with the
fingers, out of the corner towards the middle of the wall, where the hand's 20.8 cm housing fits along it.
(A fingertip dragging a flat object by its top cannot: the object-floor contact has the finger's friction
and the pressing force on top as well.)

:func:`plan_slide` works on the same observations as :func:`ferrobot.pipeline.push.plan_push` (a
:class:`~ferrobot.pipeline.push.Heightmap` of the labelled cloud and the camera's
:class:`~ferrobot.pipeline.push.FreeSpace`). A *wall* of the target is a column taller than the target's top by 1 cm
(a bin wall or a taller neighbour), within ``wall_gap`` of its footprint (or up to ``hidden_gap`` further with only
unobserved columns in between: the floor a wall hides from the camera) on one of ``num_directions`` horizontal sides
(n: the direction from the wall to the object). For each such wall and each way along it (t, perpendicular to n),
the closed fingers start ``margin + clearance`` off the object's face on the +n side, at a fingertip height of at
most 75 % of the object's height, at a few places along that face, the hand upright or leaning (back from the wall,
or along t), the closing axis along t or along n. The motion has three legs: down the approach to the start (5 cm;
the hand's solids clear of everything observed and of the target's columns, the space the target alone hides from
the camera counting as free: the fingers go down beside its far side); towards the wall by the standoff plus
``press`` (the hand's drive is position- controlled: the fingers stop at the object's face and press it against the
wall with the drive's stiffness times the overlap; the hand is checked to the face plus ``reach``); then along t by
the slide distance (both legs clear of everything but the target). The object's footprint moved along t (half a cell
off the wall it slides on) must not run into anything taller than its top plus 1 cm. Among the feasible slides, the
one leaving the object the most free room on both sides along the wall wins (its smaller gap along t to the next
obstacle: the housing needs room along the wall), then the one pressing nearest the face's middle, the least tilted.
Nothing is simulated here: the plan is hand poses (world frame) for an executor.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidArgumentError
from .push import FreeSpace, Heightmap, _checked_motion, _collides, _hand_samples, hand_rotation

__all__ = ["SlidePlan", "plan_slide"]


@dataclass
class SlidePlan:
    """A planned slide along a wall: the hand-link poses (4x4, world) above the start (``pre``), at the start,
    after pressing towards the wall (``pressed``) and at the end; the wall normal ``normal`` (unit, world,
    horizontal, from the wall into the bin), the slide direction ``direction`` (unit, along the wall), the
    object's intended displacement ``distance`` (m), the hand's ``press`` leg (m, towards the wall: the
    standoff plus the overlap it presses with), the fingertip (TCP) start point (world), the tilts (rad) and
    the plan's score (the object's smaller free room along the wall after the slide, m)."""

    target: int
    pre: np.ndarray
    start: np.ndarray
    pressed: np.ndarray
    end: np.ndarray
    normal: np.ndarray
    direction: np.ndarray
    distance: float
    press: float
    tip_start: np.ndarray
    tilt: float
    lean: float
    room: float
    score: float


def _room_along(hm: Heightmap, foot: np.ndarray, obstacle: np.ndarray, t: np.ndarray, limit: float) -> float:
    """Distance (m, at most ``limit``) the footprint ``foot`` (M, 2) can move along ``t`` before one of its
    cells enters an ``obstacle`` cell (or leaves the heightmap), in half-cell steps."""
    step = hm.cell / 2
    for k in range(1, int(limit / step) + 1):
        i, j, inside = hm.cells(foot + k * step * t[:2])
        if not inside.all() or obstacle[i, j].any():
            return (k - 1) * step
    return limit


def _descent_collides(hm: Heightmap, pts: np.ndarray, target: int, unknown_height: float, view) -> bool:
    """Whether hand points ``pts`` (M, 3, world) going down beside the target collide: with anything but the
    target as :func:`ferrobot.pipeline.push._collides` sees it, the space the target hides from the camera
    counting as free (its own shadow, where the fingers go down beside its far side), and with the target's
    own columns (2.5D: solid from the support to its highest observed point)."""
    if _collides(hm, pts, target, unknown_height, view):
        return True
    i, j, inside = hm.cells(pts[:, :2])
    mine = inside & (hm.label[i, j] == target)
    return bool(np.any(mine & (pts[:, 2] - hm.support_z < hm.height[i, j])))


def plan_slide(
    points,
    labels,
    target: int,
    gripper,
    support_z: float,
    bounds,
    *,
    cell: float = 0.005,
    num_directions: int = 8,
    wall_gap: float = 0.03,
    hidden_gap: float = 0.06,
    distances=(0.12, 0.10, 0.08, 0.06, 0.04),
    press: float = 0.02,
    reach: float = 0.005,
    tilts=(0.0, 0.15),
    leans=(0.0, 0.2, -0.2, 0.35, -0.35, 0.45, -0.45, 0.55, -0.55, 0.65, -0.65),
    tip_heights=(0.012, 0.016, 0.02),
    margin: float = 0.004,
    clearance: float = 0.005,
    min_gain: float = 0.02,
    unknown_height: float = 1.0,
    heightmap: Heightmap | None = None,
    view: FreeSpace | None = None,
) -> SlidePlan | None:
    """The best slide of the object labelled ``target`` along a wall (see the module's docstring), or None
    when it has no wall within ``wall_gap`` or no slide is free. Arguments as
    :func:`ferrobot.pipeline.push.plan_push`'s; ``press`` (m): how far past the object's face the fingers
    are driven towards the wall (the pressing force is the drive's stiffness times the overlap); ``reach``
    (m): how far past the face the hand is checked for collisions (the object stops the fingers); ``leans``
    (rad): the hand's tilt along the wall (positive: its top towards +t), ``tilts`` (rad): its tilt back from
    the wall; a slide must leave the object at least ``min_gain`` more room (its smaller gap along the wall)
    than it has; ``hidden_gap`` (m): how much further a wall may stand with only unobserved columns between it
    and the object. Ranges: ``num_directions`` 4-64, ``wall_gap`` in (0, 0.1] m, ``hidden_gap`` in [0, 0.1] m,
    ``distances`` in (0, 0.3] m,
    ``press`` in [0, 0.04] m, ``reach`` in [0, ``press``], ``tilts`` in [0, 1.2] rad, ``leans`` in
    [-1.2, 1.2] rad, ``tip_heights`` in [0.003, 0.1] m, ``margin`` and ``clearance`` in [0, 0.02] m,
    ``min_gain`` in [0, 0.2] m."""
    if not 4 <= int(num_directions) <= 64:
        raise InvalidArgumentError(f"num_directions: {num_directions} is outside [4, 64]")
    if not 0.0 < wall_gap <= 0.1:
        raise InvalidArgumentError(f"wall_gap: {wall_gap} m is outside (0, 0.1]")
    if not 0.0 <= hidden_gap <= 0.1:
        raise InvalidArgumentError(f"hidden_gap: {hidden_gap} m is outside [0, 0.1]")
    distances, tip_heights = _checked_motion(distances, tilts, tip_heights, margin, clearance)
    if not 0.0 <= press <= 0.04:
        raise InvalidArgumentError(f"press: {press} m is outside [0, 0.04]")
    if not 0.0 <= reach <= press:
        raise InvalidArgumentError(f"reach: {reach} m is outside [0, press = {press}]")
    if not all(-1.2 <= float(t) <= 1.2 for t in leans):
        raise InvalidArgumentError(f"leans: expected values in [-1.2, 1.2] rad, got {list(leans)}")
    if not 0.0 <= min_gain <= 0.2:
        raise InvalidArgumentError(f"min_gain: {min_gain} m is outside [0, 0.2]")
    hm = heightmap or Heightmap.from_points(points, labels, support_z, bounds, cell)
    mine = hm.label == target
    if not mine.any():
        return None
    ii, jj = np.nonzero(mine)
    foot = hm.origin + (np.column_stack([ii, jj]) + 0.5) * hm.cell
    top = float(hm.height[mine].max())
    # The fingertips press the face below 75 % of the object's height, the fingers grown by the margin 3 mm
    # above the support; an object too flat for both is not slid.
    lowest = 0.003 + margin
    if 0.75 * top < lowest:
        return None
    heights = sorted({max(lowest, min(h, 0.75 * top)) for h in tip_heights})
    # Walls (and neighbours taller than the object): what the object must not be driven into.
    tall = ((hm.height > top + 0.01) | ((hm.height < 0) & (view is None))) & ~mine
    # Whatever stands 1 cm or more above the support, not the target: the room along the wall is measured to it.
    obstacle = ((hm.height >= 0.01) | ((hm.height < 0) & (view is None))) & ~mine
    f = gripper.fingers
    samples = _hand_samples(gripper, 0.008, margin)
    tcp = np.asarray(gripper.tcp, dtype=float)
    up = np.array([0.0, 0.0, 1.0])
    step = 0.008
    descent = np.arange(0.0, 0.0501, step)
    best: SlidePlan | None = None
    for k in range(int(num_directions)):
        ang = 2 * math.pi * k / num_directions
        n = np.array([math.cos(ang), math.sin(ang), 0.0])  # from the wall into the bin
        # The wall: a tall cell within wall_gap of the footprint on its -n side, or further (up to hidden_gap
        # more) with nothing but unobserved columns in between (the floor a wall hides from the camera, where
        # the object's hidden side may reach).
        wall_at = None
        for g in np.arange(hm.cell / 2, wall_gap + hidden_gap + 1e-9, hm.cell / 2):
            i, j, inside = hm.cells(foot - g * n[:2])
            if (~inside).any() or tall[i, j].any():
                wall_at = g
                break
            if g > wall_gap and ((hm.height[i, j] >= 0) & (hm.label[i, j] != target)).any():
                break
        if wall_at is None:
            continue
        sn = foot @ n[:2]
        for sign in (1.0, -1.0):
            t = sign * np.cross(up, n)
            st = foot @ t[:2]
            room_now = min(
                _room_along(hm, foot + min(press, 0.005) * n[:2], obstacle, t, 0.15),
                _room_along(hm, foot + min(press, 0.005) * n[:2], obstacle, -t, 0.15),
            )
            # The footprint slides kept off the wall by half a cell (it slides on the wall, not into it).
            off = foot + 0.5 * hm.cell * n[:2]
            feasible = []
            for dist in distances:
                ok = True
                for s in np.arange(step, dist + 1e-9, step):
                    i, j, inside = hm.cells(off + s * t[:2])
                    if not inside.all() or tall[i, j].any():
                        ok = False
                        break
                if not ok:
                    continue
                moved = off + dist * t[:2]
                room = min(
                    _room_along(hm, moved, obstacle, t, 0.15),
                    _room_along(hm, moved, obstacle, -t, 0.15),
                )
                if room >= room_now + min_gain:
                    feasible.append((room, dist))
            if not feasible:
                continue
            feasible.sort(key=lambda rd: (-rd[0], rd[1]))
            # Places along the face to press at (the fingertips' centre): near its trailing end, its middle, near
            # its leading end (the closed fingers' 1 cm half-width from the face's ends, or 0.5 cm inside them).
            mid = 0.5 * (st.min() + st.max())
            along = [mid, st.min() + 0.01, st.max() - 0.01, st.max() - 0.005]
            for tip_z, across, lean, tilt, a_t in itertools.product(heights, (True, False), leans, tilts, along):
                # Closed fingers' half extents: along n, across (closing along t) their height, else their
                # thickness; along t the other one.
                half = f.height / 2 if across else f.thickness
                half_t = f.thickness if across else f.height / 2
                # The face where the fingers meet it: the front of the object's cells within the fingers' width
                # (irregular outlines: the bounding face is not where every part of the object is), which must
                # stand above the fingertips.
                band = np.abs(st - a_t) <= half_t
                if not band.any():
                    continue
                face = float(sn[band].max())
                if 0.75 * float(hm.height[ii[band], jj[band]].max()) < tip_z:
                    continue
                standoff = half + margin + clearance + max(0.0, top - tip_z) * math.tan(tilt)
                base_xy = a_t * t[:2] + (face + standoff) * n[:2]
                tip = np.array([*base_xy, hm.support_z + tip_z])
                a = -math.cos(tilt) * math.cos(lean) * up - math.sin(tilt) * n - math.cos(tilt) * math.sin(lean) * t
                a = a / np.linalg.norm(a)
                c = t if across else n
                c = c - (c @ a) * a
                c = c / np.linalg.norm(c)
                rg = np.column_stack([a, c, np.cross(a, c)])
                body = samples @ rg.T
                if any(_descent_collides(hm, body + tip - s * a, target, unknown_height, view) for s in descent):
                    continue
                # The fingers meet the face after the standoff's gap; the press beyond it is the drive's overlap,
                # which the object (held by the wall) takes: the hand is checked to the face plus ``reach``.
                press_leg = standoff - half + press
                contact = min(press_leg, standoff - half + reach)
                contact_tip = tip - contact * n
                if any(
                    _collides(hm, body + tip - s * n, target, unknown_height, view)
                    for s in (*np.arange(step, contact, step), contact)
                ):
                    continue
                for room, dist in feasible:
                    if any(
                        _collides(hm, body + contact_tip + s * t, target, unknown_height, view)
                        for s in (*np.arange(step, dist, step), dist)
                    ):
                        continue
                    # Pressing the face's middle turns the object least (the wall's friction acts along it).
                    score = room - 0.01 * (abs(lean) + tilt) - 0.1 * tip_z - 2.0 * abs(a_t - mid)
                    if best is None or score > best.score:
                        rot = hand_rotation(gripper, a, c)
                        start = np.eye(4)
                        start[:3, :3] = rot
                        start[:3, 3] = tip - rot @ tcp
                        pre, pressed, end = start.copy(), start.copy(), start.copy()
                        pre[:3, 3] -= 0.05 * a
                        pressed[:3, 3] -= press_leg * n
                        end[:3, 3] = pressed[:3, 3] + dist * t
                        best = SlidePlan(
                            target, pre, start, pressed, end, n, t, dist, press_leg, tip, tilt, lean, room, score
                        )
                    break
    return best
