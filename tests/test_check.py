"""`ferrobot check`: each defect of small broken URDFs found at the right line,
the tree compared with urdfdom's `check_urdf`, the shipped robots clean of errors,
exit statuses for CI."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from ferrobot._core import urdf_check
from ferrobot.cli import main

SHARED = Path(__file__).resolve().parents[1] / ".." / "shared" / "robots"

GOOD_LINK = """  <link name="{name}">
    <inertial>
      <mass value="1.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
    <collision><geometry><box size="0.1 0.1 0.3"/></geometry></collision>
  </link>
"""


def joint(name, parent, child, extra='<axis xyz="0 0 1"/>\n    <limit lower="-1" upper="1" effort="10" velocity="1"/>'):
    return f"""  <joint name="{name}" type="revolute">
    <parent link="{parent}"/>
    <child link="{child}"/>
    <origin xyz="0 0 0.4"/>
    {extra}
  </joint>
"""


def write(tmp_path: Path, body: str) -> Path:
    p = tmp_path / "r.urdf"
    p.write_text('<?xml version="1.0"?>\n<robot name="r">\n' + body + "</robot>\n")
    return p


def line_of(path: Path, needle: str) -> int:
    for i, line in enumerate(path.read_text().splitlines(), 1):
        if needle in line:
            return i
    raise AssertionError(needle)


def findings(path, **kw):
    return urdf_check(str(path), skip_coverage=kw.pop("skip_coverage", True), **kw).findings


def only(fs, code):
    hits = [f for f in fs if f.code == code]
    assert len(hits) == 1, (code, fs)
    return hits[0]


def test_clean_two_link_robot(tmp_path):
    p = write(tmp_path, GOOD_LINK.format(name="a") + GOOD_LINK.format(name="b") + joint("j", "a", "b"))
    fs = findings(p)
    assert not [f for f in fs if f.severity in ("error", "warning")], fs


@pytest.mark.parametrize(
    "defect, code, severity, needle",
    [
        ('<mass value="-2.0"/>', "non-positive-mass", "error", "<inertial>"),
        ('<mass value="0"/>', "zero-mass", "warning", "<inertial>"),
    ],
)
def test_mass_defects(tmp_path, defect, code, severity, needle):
    bad = GOOD_LINK.format(name="b").replace('<mass value="1.0"/>', defect)
    p = write(tmp_path, GOOD_LINK.format(name="a") + bad + joint("j", "a", "b"))
    f = only(findings(p), code)
    assert f.severity == severity and f.element == "b"
    # The second link's <inertial> (the first belongs to link a).
    lines = [i for i, s in enumerate(p.read_text().splitlines(), 1) if needle in s]
    assert f.line == lines[1]


def test_missing_inertial_is_a_warning_at_the_link(tmp_path):
    bad = '  <link name="b">\n    <collision><geometry><sphere radius="0.1"/></geometry></collision>\n  </link>\n'
    p = write(tmp_path, GOOD_LINK.format(name="a") + bad + joint("j", "a", "b"))
    f = only(findings(p), "missing-inertial")
    assert f.severity == "warning" and f.line == line_of(p, '<link name="b">')


def test_inertia_triangle_and_definiteness(tmp_path):
    # Diagonal (1, 1, 3): positive definite but 3 > 1 + 1 (hand check of the triangle inequality).
    tri = GOOD_LINK.format(name="b").replace('izz="0.01"', 'izz="0.03"')
    # Off-diagonal: [[1, 2, 0], [2, 1, 0], [0, 0, 1]] has eigenvalues -1, 1, 3 (not positive definite),
    # although every diagonal entry is positive.
    nonpd = (
        GOOD_LINK.format(name="c")
        .replace('ixx="0.01" ixy="0"', 'ixx="1" ixy="2"')
        .replace('iyy="0.01"', 'iyy="1"')
        .replace('izz="0.01"', 'izz="1"')
    )
    p = write(tmp_path, GOOD_LINK.format(name="a") + tri + nonpd + joint("j", "a", "b") + joint("k", "b", "c"))
    fs = findings(p)
    t = only(fs, "inertia-triangle")
    assert t.element == "b" and t.line == line_of(p, 'izz="0.03"')
    n = only(fs, "inertia-not-positive-definite")
    assert n.element == "c" and n.line == line_of(p, 'ixy="2"')


def test_missing_limits_effort_velocity(tmp_path):
    no_limit = joint("j", "a", "b", extra='<axis xyz="0 0 1"/>')
    no_eff = joint("k", "b", "c", extra='<axis xyz="0 0 1"/>\n    <limit lower="-1" upper="1"/>')
    p = write(tmp_path, "".join(GOOD_LINK.format(name=n) for n in "abc") + no_limit + no_eff)
    fs = findings(p)
    f = only(fs, "missing-limit")
    assert f.severity == "error" and f.line == line_of(p, '<joint name="j"')
    e = only(fs, "missing-effort")
    v = only(fs, "missing-velocity")
    assert e.line == v.line == line_of(p, '<limit lower="-1" upper="1"/>')
    assert e.severity == "warning" and e.element == "k"


def test_axes(tmp_path):
    zero = joint("j", "a", "b", extra='<axis xyz="0 0 0"/>\n    <limit lower="-1" upper="1" effort="1" velocity="1"/>')
    long = joint("k", "b", "c", extra='<axis xyz="0 0 2"/>\n    <limit lower="-1" upper="1" effort="1" velocity="1"/>')
    p = write(tmp_path, "".join(GOOD_LINK.format(name=n) for n in "abc") + zero + long)
    fs = findings(p)
    assert only(fs, "zero-axis").line == line_of(p, 'xyz="0 0 0"')
    f = only(fs, "non-unit-axis")
    assert f.line == line_of(p, 'xyz="0 0 2"') and f.severity == "warning"
    # A zero axis stops loading: one error for it, and the loader's own message.
    assert any(f.code == "skipped" for f in fs)


def test_unreachable_mesh_lists_paths(tmp_path):
    mesh = GOOD_LINK.format(name="b").replace(
        '<box size="0.1 0.1 0.3"/>', '<mesh filename="package://nopkg/meshes/arm.stl"/>'
    )
    p = write(tmp_path, GOOD_LINK.format(name="a") + mesh + joint("j", "a", "b"))
    f = only(findings(p), "mesh-not-found")
    assert f.line == line_of(p, "nopkg") and f.severity == "error"
    assert "tried" in f.message and str(tmp_path) in f.message


def test_self_collision_at_home(tmp_path):
    # Two boxes on a fixed... revolute joint at zero offset overlap at home; a third link
    # joined to b collides with a (not adjacent, not excluded).
    body = (
        "".join(GOOD_LINK.format(name=n) for n in "abc")
        + joint("j", "a", "b").replace('xyz="0 0 0.4"', 'xyz="0 0 0.35"')
        + joint("k", "b", "c").replace('xyz="0 0 0.4"', 'xyz="0 0 -0.3"')
    )
    p = write(tmp_path, body)
    fs = findings(p)
    hits = [f for f in fs if f.code == "self-collision" and f.severity == "warning"]
    assert len(hits) == 1, fs
    assert {hits[0].element, *[w.strip("'") for w in hits[0].message.split() if w.startswith("'")]} >= {"a", "c"}


def test_tree_matches_check_urdf_and_shipped_robots_have_no_errors(tmp_path):
    for name in ("panda", "ur5"):
        urdf = SHARED / name / f"{name}.urdf"
        rep = urdf_check(str(urdf), srdf=str(SHARED / name / f"{name}.srdf"), skip_coverage=True)
        errors = [f for f in rep.findings if f.severity == "error"]
        assert not errors, errors
        tool = shutil.which("check_urdf")
        if tool:
            out = subprocess.run([tool, str(urdf)], capture_output=True, text=True, timeout=60).stdout
            ref = [ln for ln in out.splitlines() if ln.startswith(("robot name", "root Link", " ", "---"))]

            # Same tree; siblings are in file order here, in joint-name order in urdfdom.
            def norm(lines):
                return sorted(re.sub(r"child\(\d+\)", "child", ln) for ln in lines)

            assert norm(rep.tree.splitlines()) == norm(ref)
            if name == "panda":  # no branching ambiguity: identical text
                assert rep.tree.splitlines() == ref


def test_coverage_on_shipped_panda():
    rep = urdf_check(str(SHARED / "panda" / "panda.urdf"))
    cov = [f for f in rep.findings if f.code == "sphere-coverage"]
    assert len(cov) >= 8
    for f in cov:
        pct = float(f.message.split("%")[0].split()[-1]) if "%" in f.message else 100.0
        assert 0.0 <= pct <= 100.0


def test_cli_exit_status_and_json(tmp_path, capsys):
    good = write(tmp_path, GOOD_LINK.format(name="a") + GOOD_LINK.format(name="b") + joint("j", "a", "b"))
    assert main(["check", str(good), "--no-coverage"]) == 0
    warn_only = write(
        tmp_path,
        GOOD_LINK.format(name="a")
        + GOOD_LINK.format(name="b")
        + joint("j", "a", "b", extra='<axis xyz="0 0 1"/>\n    <limit lower="-1" upper="1" velocity="1"/>'),
    )
    assert main(["check", str(warn_only), "--no-coverage"]) == 0
    assert main(["check", str(warn_only), "--no-coverage", "--strict"]) == 1
    bad = write(tmp_path, GOOD_LINK.format(name="a").replace('value="1.0"', 'value="-1"'))
    capsys.readouterr()
    assert main(["check", str(bad), "--no-coverage", "--json"]) == 1
    out = json.loads(capsys.readouterr().out)
    assert out["counts"]["error"] == 1 and not out["ok"]
    assert main(["check", "panda", "--no-coverage"]) == 0


def test_unreadable_file_raises():
    from ferrobot.errors import FileFormatError

    with pytest.raises(FileFormatError, match="path"):
        urdf_check("/nonexistent/robot.urdf")


def test_bundled_panda_home_self_collision_is_real_per_pybullet(tmp_path):
    """At the bundled Panda's home (every joint 0 clamped into its limits: joint 4 at -0.07 rad) the
    check reports panda_link5 touching panda_hand and panda_link7. That is not a coarse-sphere false
    alarm: PyBullet, on the same URDF's exact collision primitives, finds those pairs penetrating by
    centimetres, and every pair PyBullet finds penetrating (outside the SRDF's disabled pairs) is reported."""
    pybullet = pytest.importorskip("pybullet")
    import numpy as np

    from ferrobot import _core, robots

    urdf, srdf, _ = _core.bundled_robot("panda")
    up, sp = tmp_path / "panda.urdf", tmp_path / "panda.srdf"
    up.write_text(urdf)
    sp.write_text(srdf)
    report = urdf_check(str(up), srdf=str(sp), skip_coverage=True)
    reported = set()
    for f in report.findings:
        if f.code == "self-collision" and f.severity == "warning" and "state 'home'" in f.message:
            a, b = re.findall(r"link '([^']+)'", f.message)[:2]
            reported.add(frozenset((a, b)))
    assert frozenset(("panda_link5", "panda_hand")) in reported
    model = robots.panda()
    disabled = {frozenset(p) for p in re.findall(r'link1="([^"]+)"\s+link2="([^"]+)"', srdf)}
    cid = pybullet.connect(pybullet.DIRECT)
    try:
        rid = pybullet.loadURDF(str(up), useFixedBase=True, physicsClientId=cid)
        n = pybullet.getNumJoints(rid, physicsClientId=cid)
        info = [pybullet.getJointInfo(rid, j, physicsClientId=cid) for j in range(n)]
        joint_of = {i[1].decode(): i[0] for i in info}
        link_of = {i[12].decode(): i[0] for i in info}
        q = model.neutral_configuration()
        for name, v in zip(model.dof_names, q, strict=True):
            pybullet.resetJointState(rid, joint_of[name], v, physicsClientId=cid)
        penetrating = {}
        names = [k for k in link_of if pybullet.getCollisionShapeData(rid, link_of[k], physicsClientId=cid)]
        for i, a in enumerate(names):
            for b in names[i + 1 :]:
                if frozenset((a, b)) in disabled:
                    continue
                pts = pybullet.getClosestPoints(rid, rid, 0.0, link_of[a], link_of[b], physicsClientId=cid)
                d = min((p[8] for p in pts), default=np.inf)
                if d < -1e-3:
                    penetrating[frozenset((a, b))] = d
    finally:
        pybullet.disconnect(cid)
    assert penetrating[frozenset(("panda_link5", "panda_hand"))] < -0.03  # about 65 mm deep
    assert set(penetrating) <= reported, (penetrating, reported)
