"""The simulated robot's joint-space mass matrix (the vendored Rapier multibody's
composite-rigid-body algorithm) against Pinocchio's ``crba`` on the same URDF, an
independent implementation. Rapier computes in f32, so the agreement is to f32
precision (5e-5 of the matrix's largest entry; measured up to about 1.1e-5), not 1e-9."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import ferrobot
from conftest import PANDA_URDF


def pin_mass_matrix(pm, pdata, model, q):
    """Pinocchio's M over our DOFs, mimic joints as independent joints held at
    their coupled value (Rapier couples them by a constraint, not through M)."""
    dof_index = {name: i for i, name in enumerate(model.dof_names)}
    mimic = dict(model.mimic_joints)
    qp = pin.neutral(pm)
    for jid in range(1, pm.njoints):
        name, idx = pm.names[jid], pm.idx_qs[jid]
        if pm.nqs[jid] == 0:
            continue
        if name in dof_index:
            qp[idx] = q[dof_index[name]]
        elif name in mimic:
            driver, mult, off = mimic[name]
            qp[idx] = mult * q[dof_index[driver]] + off
    m = pin.crba(pm, pdata, qp)
    m = np.triu(m) + np.triu(m, 1).T
    cols = [pm.idx_vs[pm.getJointId(n)] for n in model.dof_names]
    return m[np.ix_(cols, cols)]


CASES = {
    "bundled_panda": (ferrobot.robots.panda, lambda: pin.buildModelFromXML(ferrobot.robots.panda_urdf())),
    "mbm_panda": (
        lambda: ferrobot.RobotModel.from_urdf(PANDA_URDF),
        lambda: pin.buildModelFromUrdf(str(PANDA_URDF)),
    ),
}


@pytest.mark.parametrize(
    "which",
    [
        "bundled_panda",
        pytest.param(
            "mbm_panda",
            marks=pytest.mark.xfail(
                strict=True,
                reason="open: M differs from Pinocchio by a rotational inertia of 0.2 kg m^2 (isotropic) on "
                "the hand body, which merges the fingers (fixed joints here, 0.1 kg m^2 each); masses agree; "
                "not yet known whether the fixed-joint merge in ferrobot-sim or the reference is at fault",
            ),
        ),
    ],
)
def test_mass_matrix_matches_pinocchio_crba(which):
    make_model, make_pin = CASES[which]
    model = make_model()
    pm = make_pin()
    pdata = pm.createData()
    w = ferrobot.World(ground=False, gravity=[0.0, 0.0, 0.0])
    r = w.add_robot(model)
    lo, hi = np.array(model.lower_limits), np.array(model.upper_limits)
    rng = np.random.default_rng(7)
    # The stepped configurations are free of self-collision (ferrobot's sphere model, which
    # encloses the links): a contact within the step pushes the mimic finger off its coupled value
    # (measured: 1.65 mm), while the reference holds it there.
    free = ferrobot.CollisionChecker(model)
    checked = 0
    for k in range(40):
        q = lo + rng.random(model.num_dof) * (hi - lo)
        while k % 2 and free.in_collision(q):
            q = lo + rng.random(model.num_dof) * (hi - lo)
        r.set_joint_positions(q)
        if k % 2:
            # After a step with the arm moving: the matrix of the new pose.
            r.set_joint_velocities(rng.uniform(-0.5, 0.5, model.num_dof))
            w.step()
            q = r.joint_positions
        m = r.mass_matrix()
        ref = pin_mass_matrix(pm, pdata, model, q)
        assert m.shape == ref.shape == (model.num_dof, model.num_dof)
        assert m.dtype == np.float64
        scale = np.abs(ref).max()
        err = np.abs(m - ref)
        assert err.max() <= 5e-5 * scale, (which, k, err.max(), scale)
        assert np.all(err <= 1e-4 * np.abs(ref) + 2e-5 * scale), (which, k, (err / scale).max())
        np.testing.assert_allclose(m, m.T, rtol=0, atol=1e-7 * scale)
        assert np.all(np.linalg.eigvalsh(m) > 0)
        checked += 1
    assert checked == 40


def test_mass_matrix_of_a_pendulum_is_its_pivot_inertia():
    """A hand derivation: a uniform rod-like cylinder on a hinge at one end."""
    length, mass, radius = 0.5, 1.3, 0.02
    urdf = f"""<robot name="p"><link name="base"/>
<link name="rod"><inertial><origin xyz="0 0 {-length / 2}"/><mass value="{mass}"/>
<inertia ixx="{mass * (3 * radius**2 + length**2) / 12}" iyy="{mass * (3 * radius**2 + length**2) / 12}"
 izz="{mass * radius**2 / 2}" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="j" type="revolute"><parent link="base"/><child link="rod"/><origin xyz="0 0 1"/>
<axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="10" velocity="5"/></joint></robot>"""
    w = ferrobot.World(ground=False)
    r = w.add_robot(ferrobot.RobotModel.from_urdf_string(urdf), gravity_compensation=False)
    expected = mass * (3 * radius**2 + length**2) / 12 + mass * (length / 2) ** 2
    for q in (0.0, 0.7, -2.0):
        r.set_joint_positions([q])
        np.testing.assert_allclose(r.mass_matrix(), [[expected]], rtol=1e-6)
