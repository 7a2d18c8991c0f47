"""Robot descriptions as they are found (issue 17, deliverables 5 and 6): spherized URDFs keep
their spheres, stale SRDFs load with warnings, links overlapping by design are found and
disabled, start/goal configurations a few µrad outside a limit are clamped, branched robots
without a group name the choices."""

from __future__ import annotations

import sys
import sysconfig
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import ferrobot
from conftest import PANDA_URDF
from ferrobot import errors as E

SHARED_ROBOTS = PANDA_URDF.parent.parent
ERD = next(
    (
        Path(root) / "cmeel.prefix/share/example-robot-data/robots"
        for root in [sysconfig.get_paths()["purelib"], *sys.path]
        if (Path(root) / "cmeel.prefix/share/example-robot-data/robots").is_dir()
    ),
    Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix/share/example-robot-data/robots",
)
needs_erd = pytest.mark.skipif(not ERD.is_dir(), reason="pip install example-robot-data (in the test extra)")


def _urdf_spheres(path: Path) -> dict[str, list[tuple[float, float, float, float]]]:
    """The sphere collision elements of a URDF, read with ElementTree (independent of ferrobot)."""
    out: dict[str, list] = {}
    for link in ET.parse(path).getroot().iter("link"):
        for col in link.iter("collision"):
            sphere = col.find("geometry/sphere")
            origin = col.find("origin")
            xyz = [float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
            out.setdefault(link.get("name"), []).append((*xyz, float(sphere.get("radius"))))
    return out


@pytest.mark.parametrize("rel", ["panda/panda_spherized.urdf", "ur5/ur5_spherized.urdf"])
def test_spherized_urdf_robot_uses_its_own_spheres(rel):
    path = SHARED_ROBOTS / rel
    model = ferrobot.RobotModel.from_urdf(path)
    reference = _urdf_spheres(path)
    for spheres in [ferrobot.SphereModel.automatic(model), ferrobot.Planner(model).sphere_model]:
        assert spheres.count == sum(len(v) for v in reference.values())
        for link, ref in reference.items():
            got = np.asarray(spheres.spheres(link))
            np.testing.assert_allclose(
                sorted(map(tuple, got)), sorted(ref), rtol=0, atol=1e-12, err_msg=f"{rel}: {link}"
            )
    report = ferrobot.SphereModel.automatic(model).report
    assert all(r.max_protrusion == 0.0 for r in report)


# --- SRDF as found: warn and skip like MoveIt's srdfdom, strict=True raises ---------------------


STALE_SRDF = """<robot name="panda">
  <group name="arm"><chain base_link="panda_link0" tip_link="panda_link8"/><joint name="ghost_joint"/></group>
  <group name="ghosts"><joint name="ghost_joint"/></group>
  <group_state name="no_group"><joint name="panda_joint1" value="0"/></group_state>
  <group_state name="home" group="arm"><joint name="panda_joint1" value="0.5"/>
    <joint name="ghost_joint" value="1"/></group_state>
  <disable_collisions link1="panda_link0" link2="ghost_link" reason="Never"/>
  <disable_collisions link1="panda_link0" link2="panda_link2" reason="Never"/>
</robot>"""


def test_stale_srdf_loads_with_warnings_and_strict_raises():
    with pytest.warns(E.SrdfWarning) as record:
        model = ferrobot.RobotModel.from_urdf(PANDA_URDF, srdf=STALE_SRDF, group="arm")
    text = str(record[0].message)
    skipped = model.srdf_warnings
    assert len(skipped) == 6, skipped
    for needle in ["ghost_joint", "'ghosts' names nothing", "needs a 'group'", "ghost_link"]:
        assert needle in text, needle
    # What is valid is kept: the group, the state (minus the unknown joint), the known pair.
    assert model.group_names == ["arm"]
    assert model.named_state("home")[0] == 0.5
    pairs = {(a, b): r for a, b, r in ferrobot.CollisionChecker(model).allowed_collision_pairs}
    assert pairs[("panda_link0", "panda_link2")] == "Never"
    with pytest.raises(E.SrdfError, match=r"<srdf string>:4: <group_state name=\"no_group\"> needs a 'group'"):
        ferrobot.RobotModel.from_urdf(PANDA_URDF, srdf=STALE_SRDF, strict=True)
    fixed_state = STALE_SRDF.replace(' name="no_group"', ' name="s" group="arm"')
    with pytest.raises(E.SrdfError, match=r"<srdf string>:2: group 'arm' names joint 'ghost_joint'"):
        ferrobot.RobotModel.from_urdf(PANDA_URDF, srdf=fixed_state, strict=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert ferrobot.robots.panda().srdf_warnings == []


@needs_erd
@pytest.mark.parametrize(
    ("urdf", "srdf", "needle"),
    [
        ("kinova_description/robots/kinova.urdf", "kinova_description/srdf/kinova.srdf", "needs a 'group'"),
        ("z1_description/urdf/z1.urdf", "z1_description/srdf/z1.srdf", "needs a 'group'"),
        ("baxter_description/urdf/baxter.urdf", "baxter_description/srdf/baxter_manipulation.srdf", "joint"),
    ],
)
def test_shipped_srdfs_that_srdfdom_accepts_load(urdf, srdf, needle):
    ee = "left_gripper" if "baxter" in urdf else None
    with pytest.warns(E.SrdfWarning, match=needle):
        model = ferrobot.RobotModel.from_urdf(ERD / urdf, srdf=ERD / srdf, ee_link=ee)
    assert model.srdf_warnings
    with pytest.raises(E.SrdfError):
        ferrobot.RobotModel.from_urdf(ERD / urdf, srdf=ERD / srdf, ee_link=ee, strict=True)


# --- Branched robots -----------------------------------------------------------------------------


@needs_erd
def test_branched_robot_without_group_names_the_choices():
    urdf = ERD / "baxter_description/urdf/baxter.urdf"
    with pytest.raises(
        E.InvalidArgumentError, match=r"no single default arm.*ee_link=.*(left.*right|right.*left)_gripper"
    ):
        ferrobot.RobotModel.from_urdf(urdf)
    model = ferrobot.RobotModel.from_urdf(urdf, ee_link="right_gripper")
    assert len(model.group_dof_names) == 7 and all(n.startswith("right_") for n in model.group_dof_names)


# --- Links overlapping by design -----------------------------------------------------------------


def _overlap_urdf() -> str:
    """Coaxial z joints: `a` and `c` are concentric 10 cm cubes turning about the same axis, so
    they overlap in every configuration (both hold the 5 cm ball about the axis point). `far`, a
    10 cm cube 12 cm out on an arm swinging about y, has its near face 7 cm from the axis point:
    `a` (|x| <= 0.05 unturned, corners out to 0.0707 turned 45 degrees) touches it only in some
    configurations."""
    box = '<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>'
    lim = '<limit lower="-3" upper="3" effort="1" velocity="1"/>'
    return f"""<robot name="overlap">
  <link name="base"/>
  <link name="a">{box}</link><link name="b"/><link name="c">{box}</link>
  <link name="arm"/><link name="far">{box}</link>
  <joint name="ja" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>{lim}</joint>
  <joint name="jb" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>{lim}</joint>
  <joint name="jc" type="revolute"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/>{lim}</joint>
  <joint name="jarm" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>{lim}</joint>
  <joint name="jfar" type="fixed"><parent link="arm"/><child link="far"/><origin xyz="0.12 0 0"/></joint>
</robot>"""


def test_pairs_in_contact_everywhere_are_disabled_and_reported():
    model = ferrobot.RobotModel.from_urdf_string(_overlap_urdf(), ee_link="c")
    assert model.dof_names == ["ja", "jb", "jc", "jarm"]
    with pytest.warns(UserWarning, match=r"1 link pair.*a-c"):
        checker = ferrobot.CollisionChecker(model)
    reasons = {(a, b): r for a, b, r in checker.allowed_collision_pairs}
    assert reasons[("a", "c")] == "Always (automatic)"
    assert ("a", "far") not in reasons and ("c", "far") not in reasons
    # The sometimes-touching pairs are still checked, against the hand derivation above.
    # `a` turned by t reaches x = 0.05 (cos t + sin t); `far` starts at x = 0.07.
    assert not checker.in_collision(np.zeros(4))  # 2 cm apart
    assert not checker.in_collision(np.array([0.3, 0, 0, 0]))  # reaches 0.0626: 7.4 mm apart
    assert checker.in_collision(np.array([np.pi / 4, 0, 0, 0]))  # reaches 0.0707: 0.7 mm in
    # Cached per model: a second checker does not analyse (nor warn) again.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ferrobot.CollisionChecker(model)
    # An SRDF that disables the pair already: nothing is added, nothing reported.
    srdf = '<robot name="overlap"><disable_collisions link1="a" link2="c" reason="Default"/></robot>'
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        covered = ferrobot.RobotModel.from_urdf_string(_overlap_urdf(), srdf=srdf, ee_link="c")
        reasons = {(a, b): r for a, b, r in ferrobot.CollisionChecker(covered).allowed_collision_pairs}
    assert reasons[("a", "c")] == "Default"


def _gripper_urdf(finger_y: float) -> str:
    """A palm turning about z (the planning group, ee_link `palm`), two fingers on prismatic y
    joints (`jr` mimics `jl`, range 0-4 cm): 1 cm thick boxes centred at y = +-finger_y plus the
    opening, so closed they overlap by 2 (0.005 - finger_y). A two-segment finger on the palm: `s2`
    rides on two prismatic z joints (`jv`, `js`, 0-5 cm) over `s1`, overlapping it by 4 mm when
    both are at 0 (its bottom at z = 0.026 below the 0.03 top of `s1`)."""
    lim = '<limit lower="0" upper="0.04" effort="1" velocity="1"/>'
    zlim = '<limit lower="0" upper="0.05" effort="1" velocity="1"/>'

    def box(size, xyz):
        return f'<collision><origin xyz="{xyz}"/><geometry><box size="{size}"/></geometry></collision>'

    return f"""<robot name="gripper">
  <link name="base"/>
  <link name="palm">{box("0.1 0.1 0.02", "0 0 0")}</link>
  <link name="left">{box("0.01 0.01 0.05", f"0 {finger_y} 0.035")}</link>
  <link name="right">{box("0.01 0.01 0.05", f"0 {-finger_y} 0.035")}</link>
  <link name="s1">{box("0.01 0.01 0.03", "0 0 0.015")}</link>
  <link name="v"/>
  <link name="s2">{box("0.01 0.01 0.03", "0 0 0.015")}</link>
  <joint name="jarm" type="revolute"><parent link="base"/><child link="palm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="jl" type="prismatic"><parent link="palm"/><child link="left"/><axis xyz="0 1 0"/>{lim}</joint>
  <joint name="jr" type="prismatic"><parent link="palm"/><child link="right"/><axis xyz="0 -1 0"/>{lim}
    <mimic joint="jl"/></joint>
  <joint name="js1" type="fixed"><parent link="palm"/><child link="s1"/><origin xyz="0.03 0.03 0.01"/></joint>
  <joint name="jv" type="prismatic"><parent link="s1"/><child link="v"/><origin xyz="0 0 0.026"/>
    <axis xyz="0 0 1"/>{zlim}</joint>
  <joint name="js" type="prismatic"><parent link="v"/><child link="s2"/><axis xyz="0 0 1"/>{zlim}</joint>
</robot>"""


def test_pairs_touching_at_a_stop_or_at_rest_are_disabled_and_reported():
    # Fingers overlapping by 0.2 mm when closed (finger_y 0.0049), apart from the next tried
    # opening (4 cm / 63 = 0.63 mm): touching at the stop only, like pybullet's Panda fingers.
    model = ferrobot.RobotModel.from_urdf_string(_gripper_urdf(0.0049), ee_link="palm")
    assert model.dof_names == ["jarm", "jl", "jv", "js"]
    with pytest.warns(UserWarning, match=r"left-right \(Stop \(automatic\)\).*s1-s2 \(Default \(automatic\)\)"):
        checker = ferrobot.CollisionChecker(model)
    reasons = {(a, b): r for a, b, r in checker.allowed_collision_pairs}
    assert reasons[("left", "right")] == "Stop (automatic)"
    # s1-s2: two DOFs between them, neither in the planning group, 4 mm deep at rest.
    assert reasons[("s1", "s2")] == "Default (automatic)"
    assert not checker.in_collision(np.zeros(4))
    # Fingers overlapping by 10 mm when closed (finger_y 0): in contact over the first 5 mm of
    # the opening, a real collision, not a stop. With the finger in the planning group (ee_link
    # `left`: jarm, jl) the pair stays checked; with the palm as ee_link no planned joint moves
    # the fingers and the pair, in contact at rest, is disabled as MoveIt's `Default`.
    at_rest = ferrobot.RobotModel.from_urdf_string(_gripper_urdf(0.0), ee_link="palm")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        reasons = {(a, b): r for a, b, r in ferrobot.CollisionChecker(at_rest).allowed_collision_pairs}
    assert reasons[("left", "right")] == "Default (automatic)"
    deep = ferrobot.RobotModel.from_urdf_string(_gripper_urdf(0.0), ee_link="left")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        checker = ferrobot.CollisionChecker(deep)
    reasons = {(a, b): r for a, b, r in checker.allowed_collision_pairs}
    assert ("left", "right") not in reasons
    assert checker.in_collision(np.array([0.0, 0.004, 0.01, 0.0]))  # 2 mm deep
    assert not checker.in_collision(np.array([0.0, 0.006, 0.01, 0.0]))  # 2 mm apart


# --- Limits: clamp within 1e-5, reject beyond --------------------------------------------------


def test_start_and_goal_slightly_outside_a_limit_are_clamped():
    panda = ferrobot.robots.panda()
    planner = ferrobot.Planner(panda)
    ready = panda.named_state("ready")[:7]
    lo, hi = panda.lower_limits[:7], panda.upper_limits[:7]
    start, goal = ready.copy(), ready.copy()
    start[0] = hi[0] + 2.65e-6  # as recorded in benchmark problems
    goal[6] = lo[6] - 9e-6
    result = planner.plan(start, goal_q=goal)
    assert result.success, result.message
    traj = result.interpolated(dt=0.01).positions
    assert np.all(traj >= lo) and np.all(traj <= hi)
    assert traj[0][0] == hi[0] and traj[-1][6] == lo[6]
    start[0] = hi[0] + 2e-5  # beyond the documented 1e-5 tolerance
    result = planner.plan(start, goal_q=goal)
    assert result.status == "start_out_of_limits" and "panda_joint1" in result.message
    start[0] = hi[0]
    goal[6] = lo[6] - 2e-5
    result = planner.plan(start, goal_q=goal)
    assert result.status == "goal_out_of_limits" and "panda_joint7" in result.message
