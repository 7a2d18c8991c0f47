"""FK and Jacobians against Pinocchio (an independent implementation), 1,000
random configurations per robot, to 1e-9."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import ferrobot
from conftest import PANDA_URDF, UR5_URDF, random_configurations

N = 1000
TOL = 1e-9


def pin_model_from(model: ferrobot.RobotModel, urdf_path=None, urdf_text=None):
    """Pinocchio model of the same URDF (mimic joints as mimic) and a map from our
    DOF vector to Pinocchio's q."""
    if urdf_path is not None:
        pm = pin.buildModelFromUrdf(str(urdf_path), mimic=True)
    else:
        pm = pin.buildModelFromXML(urdf_text, mimic=True)
    dof_index = {name: i for i, name in enumerate(model.dof_names)}
    mimic = dict(model.mimic_joints)

    def to_pin(q: np.ndarray) -> np.ndarray:
        out = np.zeros(pm.nq)
        for jid in range(1, pm.njoints):
            name = pm.names[jid]
            idx, nq = pm.idx_qs[jid], pm.nqs[jid]
            if nq == 0:
                continue
            if name in dof_index:
                out[idx] = q[dof_index[name]]
            elif name in mimic:  # pinocchio keeps it in q only when not handled as mimic
                driver, mult, off = mimic[name]
                out[idx] = mult * q[dof_index[driver]] + off
        return out

    # Column of Pinocchio's Jacobian for each of our DOFs.
    cols = []
    for name in model.dof_names:
        jid = pm.getJointId(name)
        cols.append(pm.idx_vs[jid])
    return pm, to_pin, np.array(cols)


CASES = {
    "mbm_panda": (lambda: ferrobot.RobotModel.from_urdf(PANDA_URDF), {"urdf_path": PANDA_URDF}),
    "ur5": (lambda: ferrobot.RobotModel.from_urdf(UR5_URDF), {"urdf_path": UR5_URDF}),
    "bundled_panda": (
        lambda: ferrobot.robots.panda(),
        {"urdf_text": ferrobot.robots.panda_urdf()},
    ),
    "bundled_ur5e": (lambda: ferrobot.robots.ur5e(), {"urdf_text": ferrobot.robots.ur5e_urdf()}),
}


@pytest.fixture(scope="module", params=list(CASES))
def case(request):
    make, src = CASES[request.param]
    model = make()
    pm, to_pin, cols = pin_model_from(model, **src)
    return request.param, model, pm, to_pin, cols


def test_every_link_pose_matches_pinocchio(case):
    name, model, pm, to_pin, _ = case
    data = pm.createData()
    frame_ids = {ln: pm.getFrameId(ln, pin.BODY) for ln in model.link_names}
    assert all(fid < pm.nframes for fid in frame_ids.values()), name
    worst = 0.0
    for q in random_configurations(model, N, seed=1):
        pin.framesForwardKinematics(pm, data, to_pin(q))
        ours = model.fk_all(q)
        for i, ln in enumerate(model.link_names):
            worst = max(worst, np.abs(ours[i] - data.oMf[frame_ids[ln]].homogeneous).max())
    assert worst < TOL, f"{name}: max FK difference {worst}"


def test_ee_fk_single_and_batch_match_pinocchio(case):
    name, model, pm, to_pin, _ = case
    data = pm.createData()
    fid = pm.getFrameId(model.ee_link, pin.BODY)
    qs = random_configurations(model, N, seed=2)
    batch = model.fk_batch(qs)
    assert batch.shape == (N, 7) and batch.dtype == np.float64
    assert np.all(batch[:, 3] >= 0.0), "quaternions are returned with w >= 0"
    for q, row in zip(qs, batch, strict=True):
        pin.framesForwardKinematics(pm, data, to_pin(q))
        ref = data.oMf[fid]
        single = model.fk(q)
        assert np.abs(single - ref.homogeneous).max() < TOL
        assert np.abs(row[:3] - ref.translation).max() < TOL
        qref = pin.Quaternion(ref.rotation)  # coeffs() is x, y, z, w
        wxyz = np.array([qref.w, qref.x, qref.y, qref.z])
        wxyz *= np.sign(wxyz[0]) if wxyz[0] != 0 else 1.0
        assert np.abs(row[3:] - wxyz).max() < TOL


@pytest.mark.parametrize("which", ["ee", "every_link"])
def test_jacobian_matches_pinocchio(case, which):
    name, model, pm, to_pin, cols = case
    data = pm.createData()
    links = [model.ee_link] if which == "ee" else model.link_names
    worst = 0.0
    n = N if which == "ee" else 50
    for q in random_configurations(model, n, seed=3):
        qp = to_pin(q)
        pin.computeJointJacobians(pm, data, qp)
        pin.updateFramePlacements(pm, data)
        for ln in links:
            fid = pm.getFrameId(ln, pin.BODY)
            ref = pin.getFrameJacobian(pm, data, fid, pin.LOCAL_WORLD_ALIGNED)[:, cols]
            worst = max(worst, np.abs(model.jacobian(q, link=ln) - ref).max())
    assert worst < TOL, f"{name}: max Jacobian difference {worst}"


def test_jacobian_matches_finite_differences_of_fk(bundled_panda):
    """Independent of Pinocchio: central differences of our own FK, mimic finger included."""
    model = bundled_panda
    for q in random_configurations(model, 20, seed=4):
        for link in ["panda_hand", "panda_rightfinger"]:
            jac = model.jacobian(q, link=link)
            h = 1e-6
            for k in range(model.num_dof):
                dq = np.zeros(model.num_dof)
                dq[k] = h
                tp, tm = model.fk(q + dq, link=link), model.fk(q - dq, link=link)
                lin = (tp[:3, 3] - tm[:3, 3]) / (2 * h)
                dr = (tp[:3, :3] - tm[:3, :3]) / (2 * h) @ model.fk(q, link=link)[:3, :3].T
                ang = np.array([dr[2, 1], dr[0, 2], dr[1, 0]])
                assert np.allclose(jac[:3, k], lin, atol=1e-7)
                assert np.allclose(jac[3:, k], ang, atol=1e-7)
