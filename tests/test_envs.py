"""ferrobot's Gymnasium environments: Gymnasium's own checker on every environment and mode, determinism,
action checks, the end-effector modes against FK, the expert baseline, evaluation outputs, vector stepping."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")
from gymnasium.utils.env_checker import check_env  # noqa: E402

import ferrobot  # noqa: E402
import ferrobot.envs  # noqa: E402
from ferrobot.envs import ACTION_MODES, ENV_IDS  # noqa: E402
from ferrobot.envs.evaluate import evaluate, wilson_interval  # noqa: E402
from ferrobot.envs.expert import ExpertPolicy  # noqa: E402
from ferrobot.errors import InvalidArgumentError, NonFiniteError, ShapeError  # noqa: E402
from ferrobot.pipeline import random_scene  # noqa: E402

SMALL = (16, 12)  # image_size of the tests: tiny frames


def make(env_id="ferrobot/PickPlace-v0", **kw):
    kw.setdefault("image_size", SMALL)
    return gym.make(env_id, **kw)


@pytest.mark.parametrize("env_id", list(ENV_IDS))
@pytest.mark.parametrize("obs_mode", ["state", "rgb", "rgbd"])
@pytest.mark.parametrize("control_mode", ACTION_MODES)
def test_check_env(env_id, obs_mode, control_mode):
    env = make(env_id, obs_mode=obs_mode, control_mode=control_mode, segmentation=obs_mode == "rgbd")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # infinite bounds and non-normalised action boxes are intended
        check_env(env.unwrapped)
    obs, info = env.reset(seed=1)
    assert env.observation_space.contains(obs)
    assert set(info) >= {"is_success", "failure_cause", "scene_seed"}
    keys = set(obs)
    assert {"observation.state", "observation.ee_pose", "observation.gripper_opening"} <= keys
    assert any(k.startswith("observation.images.") for k in keys) == (obs_mode != "state")
    assert any(k.startswith("observation.depth.") for k in keys) == (obs_mode == "rgbd")


def test_registration_in_a_fresh_interpreter():
    code = (
        "import gymnasium as gym\n"
        "env = gym.make('ferrobot.envs:ferrobot/PickPlace-v0')\n"
        "print(env.spec.id, env.spec.max_episode_steps)\n"
        "import ferrobot.envs\n"
        "print(gym.make('ferrobot/Reach-v0').spec.id)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["ferrobot/PickPlace-v0", "200", "ferrobot/Reach-v0"]


def test_reset_builds_the_seeded_scene():
    env = make()
    env.reset(seed=7)
    spec = random_scene(7)
    u = env.unwrapped
    assert u.spec_scene.to_dict() == spec.to_dict()
    for o in spec.objects:  # objects settled near their specified poses
        p = u.world.get_object_pose(o.name)[:3, 3]
        assert np.linalg.norm(p - np.asarray(o.pose[:3])) < 0.01


def test_determinism_same_seed_same_actions():
    def run():
        env = make(obs_mode="rgbd", control_mode="ee_delta")
        env.action_space.seed(3)
        obs, _ = env.reset(seed=5)
        seq = [obs]
        for _ in range(6):
            obs, *_ = env.step(env.action_space.sample())
            seq.append(obs)
        return seq

    a, b = run(), run()
    for oa, ob in zip(a, b, strict=True):
        assert oa.keys() == ob.keys()
        for k in oa:
            assert np.array_equal(oa[k], ob[k]), k


def test_bad_actions_raise_naming_the_space():
    env = make(control_mode="joint_pos")
    env.reset(seed=0)
    u = env.unwrapped
    t0 = u.world.time
    good = env.action_space.sample()
    with pytest.raises(ShapeError, match="action space"):
        env.step(good[:-1])
    nan = good.copy()
    nan[2] = np.nan
    with pytest.raises(NonFiniteError, match="action space"):
        env.step(nan)
    out = good.copy()
    out[0] = env.action_space.high[0] + 0.1
    with pytest.raises(InvalidArgumentError, match=r"out of bounds.*\[0\]"):
        env.step(out)
    grip = good.copy()
    grip[-1] = 1.5
    with pytest.raises(InvalidArgumentError, match="not clipped"):
        env.step(grip)
    assert u.world.time == t0  # nothing was stepped
    with pytest.raises(InvalidArgumentError, match="control_mode"):
        make(control_mode="torque")
    with pytest.raises(InvalidArgumentError, match="obs_mode"):
        make(obs_mode="pointcloud")


def test_joint_pos_reaches_the_commanded_configuration():
    env = make(control_mode="joint_pos", env_id="ferrobot/Reach-v0")
    obs, _ = env.reset(seed=0)
    q = obs["observation.state"].astype(np.float64)
    target = np.concatenate([q[:7] + np.array([0.2, -0.1, 0.1, 0.15, -0.1, 0.1, 0.2]), [0.0]])
    for _ in range(15):
        obs, *_ = env.step(target.astype(np.float32))
    np.testing.assert_allclose(obs["observation.state"][:7], target[:7], atol=5e-3)


def test_ee_delta_moves_the_hand_by_the_commanded_step():
    """After a translation step of 3 cm along base x (and time to settle), the hand pose measured by the
    model's FK moved by 3 cm along x with its orientation unchanged."""
    env = make(control_mode="ee_delta", env_id="ferrobot/Reach-v0")
    obs, _ = env.reset(seed=0)
    u = env.unwrapped
    before = u.model.fk(u.robot.joint_positions)
    obs, _, _, _, info = env.step(np.array([0.03, 0, 0, 0, 0, 0, 0], np.float32))
    assert not info["ik_failed"]
    for _ in range(10):  # hold: zero delta from wherever the hand is would drift; hold the joint targets instead
        u.stepper.step(np.concatenate([u._arm_target, [0.0]]))
    after = u.model.fk(u.robot.joint_positions)
    np.testing.assert_allclose(after[:3, 3] - before[:3, 3], [0.03, 0, 0], atol=2e-3)
    np.testing.assert_allclose(after[:3, :3], before[:3, :3], atol=5e-3)
    ee = obs["observation.ee_pose"]
    assert ee.shape == (7,) and abs(np.linalg.norm(ee[3:]) - 1) < 1e-5


def _panda_tcp(u) -> np.ndarray:
    """The Panda hand's TCP (Franka: 103.4 mm along the hand's z) from the hand's FK, [x, y, z, qw, qx, qy, qz]."""
    hand = u.model.fk(u.robot.joint_positions)
    tcp = hand.copy()
    tcp[:3, 3] = hand[:3, 3] + 0.1034 * hand[:3, 2]
    return ferrobot.transforms.matrix_to_pose(tcp)


def test_ee_abs_reaches_the_commanded_pose():
    """``ee_abs`` commands the gripper's TCP (the frame of ``observation.ee_pose``)."""
    env = make(control_mode="ee_abs", env_id="ferrobot/Reach-v0")
    obs, _ = env.reset(seed=0)
    u = env.unwrapped
    pose = _panda_tcp(u)
    np.testing.assert_allclose(obs["observation.ee_pose"], pose, atol=1e-6)
    pose[:3] += [0.0, 0.05, -0.04]
    for _ in range(8):
        env.step(np.concatenate([pose, [0.0]]).astype(np.float32))
    got = _panda_tcp(u)
    np.testing.assert_allclose(got[:3], pose[:3], atol=3e-3)
    assert abs(abs(np.dot(got[3:], pose[3:])) - 1) < 1e-4


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_expert_solves_pick_place(seed):
    env = make()
    obs, info = env.reset(seed=seed)
    pol = ExpertPolicy()
    pol.reset(env)
    for _ in range(200):
        obs, reward, terminated, truncated, info = env.step(pol.act(obs))
        if terminated or truncated:
            break
    assert info["is_success"] and terminated and reward == 1.0, (pol.failure, info)
    # Independently of the env's success test: the target rests within 3 cm of the place location.
    u = env.unwrapped
    p = u.world.get_object_pose(u.spec_scene.target)[:3, 3]
    assert np.hypot(*(p[:2] - np.asarray(u.spec_scene.place_xy))) < 0.03


@pytest.mark.parametrize("env_id", ["ferrobot/Lift-v0", "ferrobot/Reach-v0"])
def test_expert_solves_lift_and_reach(env_id):
    s = evaluate(env_id, ExpertPolicy, 1, seed=4, progress=False)
    assert s["successes"] == 1, s


def test_sparse_and_dense_rewards():
    env = make(reward_type="dense")
    obs, _ = env.reset(seed=0)
    hold = np.concatenate([obs["observation.state"][:7], [0.0]])
    _, r, term, _, info = env.step(hold)
    assert 0.0 < r < 0.95 and not term and info["failure_cause"] == "not_lifted"
    env = make(reward_type="sparse")
    env.reset(seed=0)
    _, r, *_ = env.step(hold)
    assert r == 0.0


def test_wilson_interval_matches_scipy():
    stats = pytest.importorskip("scipy.stats")
    for k, n in [(0, 10), (9, 10), (45, 50), (50, 50), (3, 7)]:
        ci = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
        np.testing.assert_allclose(wilson_interval(k, n), [ci.low, ci.high], atol=1e-9)


def hold_policy(obs):
    """A test policy: keep the arm where it is, gripper open."""
    return np.concatenate([obs["observation.state"][:7], [0.0]]).astype(np.float32)


def test_cli_evaluate_writes_results_and_video(tmp_path):
    av = pytest.importorskip("av")
    out = tmp_path / "eval"
    from ferrobot.cli import main

    rc = main(
        [
            "evaluate", "--env", "ferrobot/Reach-v0", "--policy", "test_envs:hold_policy", "--episodes", "3",
            "--num-envs", "2", "--seed", "10", "--out", str(out), "--max-steps", "4", "--video-episodes", "1",
            "--quiet",
        ]
    )  # fmt: skip
    assert rc == 0
    recs = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert sorted(r["seed"] for r in recs) == [10, 11, 12]
    assert all(not r["success"] and r["steps"] == 4 and r["failure_cause"] == "not_reached" for r in recs)
    s = json.loads((out / "summary.json").read_text())
    assert s["episodes"] == 3 and s["successes"] == 0 and s["failures_by_cause"] == {"not_reached": 3}
    assert s["success_rate_ci95"][0] < 1e-12 and 0.5 < s["success_rate_ci95"][1] < 0.6
    with av.open(str(out / "videos" / "episode_00001.mp4")) as f:
        frames = list(f.decode(video=0))
    assert len(frames) == 5 and frames[0].width == 320  # reset + 4 steps


@pytest.mark.parametrize("batch", ["threads", "rust"])
def test_vector_env_matches_single_envs(batch):
    venv = gym.make_vec(
        "ferrobot/Reach-v0",
        num_envs=2,
        vectorization_mode="vector_entry_point",
        max_episode_steps=3,
        batch=batch,
    )
    singles = [make("ferrobot/Reach-v0", max_episode_steps=3) for _ in range(2)]
    vobs, _ = venv.reset(seed=20)
    sobs = [e.reset(seed=20 + i)[0] for i, e in enumerate(singles)]
    rng = np.random.default_rng(0)
    for step in range(4):
        for i in range(2):
            for k in sobs[i]:
                np.testing.assert_array_equal(vobs[k][i], sobs[i][k])
        acts = np.stack([hold_policy(o) for o in sobs]) + rng.uniform(-0.02, 0.02, (2, 8)).astype(np.float32)
        acts[:, -1] = 0.0
        vobs, _, vterm, vtrunc, _ = venv.step(acts)
        if step < 3:
            sobs = [e.step(a)[0] for e, a in zip(singles, acts, strict=True)]
        else:  # next-step auto-reset: the step after truncation resets (seedless)
            assert not vtrunc.any()
        if step == 2:
            assert vtrunc.all()
    venv.close()


def test_step_worlds_equals_stepping_each_world():
    envs = [make("ferrobot/PickPlace-v0") for _ in range(3)]
    for i, e in enumerate(envs):
        e.reset(seed=i)
    worlds = [e.unwrapped.world for e in envs]
    ferrobot._core.step_worlds(worlds, 30)
    refs = [make("ferrobot/PickPlace-v0") for _ in range(3)]
    for i, e in enumerate(refs):
        e.reset(seed=i)
        e.unwrapped.world.step(30)
    for e, r in zip(envs, refs, strict=True):
        np.testing.assert_array_equal(e.unwrapped.robot.joint_positions, r.unwrapped.robot.joint_positions)
        name = e.unwrapped.spec_scene.target
        np.testing.assert_array_equal(e.unwrapped.world.get_object_pose(name), r.unwrapped.world.get_object_pose(name))
    with pytest.raises(InvalidArgumentError, match="same world"):
        ferrobot._core.step_worlds([worlds[0], worlds[1], worlds[0]], 1)
    pos = np.zeros((2, 7))
    with pytest.raises(InvalidArgumentError, match="same world"):
        ferrobot._core.execute_trajectories([worlds[0]] * 2, ["panda"] * 2, [pos, pos], 0.1, [list(range(7))] * 2)
    with pytest.raises(InvalidArgumentError, match="2 worlds but 1 robots"):
        ferrobot._core.execute_trajectories(worlds[:2], ["panda"], [pos, pos], 0.1, [list(range(7))] * 2)
    with pytest.raises(ferrobot.errors.ShapeError):
        ferrobot._core.execute_trajectories(worlds[:1], ["panda"], [np.zeros((2, 6))], 0.1, [list(range(7))])
    with pytest.raises(ferrobot.errors.UnknownNameError):
        ferrobot._core.execute_trajectories(worlds[:1], ["ur5"], [pos], 0.1, [list(range(7))])


def _record_with_expert(seed: int, steps: int = 200):
    env = make()
    obs, _ = env.reset(seed=seed)
    pol = ExpertPolicy()
    pol.reset(env)
    actions = []
    for _ in range(steps):
        a = pol.act(obs)
        actions.append(a)
        obs, _, term, trunc, info = env.step(a)
        if term or trunc:
            break
    u = env.unwrapped
    return env, np.asarray(actions), info, u.robot.joint_positions, u.world.get_object_pose(u.spec_scene.target)


def test_replay_reproduces_recorded_outcomes():
    """Episodes driven by the expert (one success) and by a random policy (a failure), stored as scene dict +
    float32 actions, replay to the same outcome and the same final state, bit for bit."""
    from ferrobot.envs.replay import RecordedEpisode, ReplayPolicy

    _, acts, info, q_end, obj_end = _record_with_expert(seed=2)
    assert info["is_success"]
    env = make()
    env.reset(seed=9)
    spec = env.unwrapped.spec_scene.to_dict()
    env.action_space.seed(0)
    rnd = np.stack([env.action_space.sample() for _ in range(5)])
    rnd[:, -1] = 0.0
    for a in rnd:
        env.step(a)
    rnd_q = env.unwrapped.robot.joint_positions
    episodes = [
        RecordedEpisode(0, random_scene(2).to_dict(), acts, True),
        RecordedEpisode(1, spec, rnd, False),
    ]
    s = evaluate("ferrobot/PickPlace-v0", ReplayPolicy(episodes), 2, seed=100, progress=False, max_episode_steps=None)
    assert s["successes"] == 1 and s["episodes"] == 2
    # Bit-exact: replay episode 0 by hand.
    pol = ReplayPolicy(episodes, fixed=0)
    env = make()
    obs, _ = env.reset(seed=0, options=pol.reset_options(0))
    pol.reset(env)
    for _ in range(len(acts)):
        obs, _, term, _, info = env.step(pol.act(obs))
    u = env.unwrapped
    assert term and info["is_success"]
    np.testing.assert_array_equal(u.robot.joint_positions, q_end)
    np.testing.assert_array_equal(u.world.get_object_pose(u.spec_scene.target), obj_end)
    pol = ReplayPolicy(episodes, fixed=1)
    env.reset(options=pol.reset_options(0))
    pol.reset(env)
    for _ in range(5):
        env.step(pol.act())
    np.testing.assert_array_equal(env.unwrapped.robot.joint_positions, rnd_q)


def test_replay_of_a_pipeline_recording_is_bit_exact():
    """An episode recorded by the dataset recorder (the pick-and-place pipeline through
    ferrobot.pipeline.recording.ControlRecorder) replays in the environment to the recorded simulator state
    after every action, bit for bit; the expert policy emits the same actions."""
    recording = pytest.importorskip("ferrobot.pipeline.recording")
    from ferrobot.envs.replay import RecordedEpisode, ReplayPolicy
    from ferrobot.pipeline import PickPlace

    frames = []
    spec = random_scene(1)

    def factory(world, robot, camera, arm_idx):
        return recording.ControlRecorder(
            world, robot, {}, frames.append, control_hz=10.0, arm_joint_names=[robot.dof_names[i] for i in arm_idx]
        )

    result = PickPlace().run(spec, recorder=factory)
    assert result.success and len(frames) > 20
    actions = np.stack([f["action"] for f in frames])
    pol = ReplayPolicy([RecordedEpisode(0, spec.to_dict(), actions, True)])
    env = make(terminate_on_success=False)
    obs, _ = env.reset(options=pol.reset_options(0))
    pol.reset(env)
    u = env.unwrapped
    success = False
    for f in frames:
        obs, _, _, _, info = env.step(pol.act(obs))
        np.testing.assert_array_equal(recording.sim_state(u.world, u.robot), f["state"])
        success = success or info["is_success"]
    assert success
    # The expert, run in the environment on the same scene, emits exactly the recorded actions.
    obs, _ = env.reset(seed=1)
    expert = ExpertPolicy()
    expert.reset(env)
    acts = []
    for _ in range(len(actions)):
        acts.append(expert.act(obs))
        obs, *_ = env.step(acts[-1])
    np.testing.assert_array_equal(np.stack(acts), actions)


def _make_in_child(q):
    try:
        gym.make("ferrobot/Reach-v0")
        q.put("made")
    except ferrobot.errors.FerrobotError as e:
        q.put(str(e))


def test_env_in_a_forked_child_raises_instead_of_hanging():
    import multiprocessing

    make("ferrobot/Reach-v0").reset(seed=0)  # the parent has used the thread pool
    ctx = multiprocessing.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_make_in_child, args=(q,))
    p.start()
    msg = q.get(timeout=60)
    p.join(timeout=30)
    assert "spawn" in msg and "fork" in msg


@pytest.mark.parametrize("fmt", ["hdf5", "lerobot"])
def test_replay_policy_reproduces_a_generated_dataset(tmp_path, fmt):
    """``ferrobot generate`` writes a dataset; ``--policy replay:DIR`` replays each episode to its recorded
    outcome (read back from the dataset with h5py / pyarrow)."""
    pytest.importorskip("ferrobot.dataset.generate")
    pytest.importorskip("h5py" if fmt == "hdf5" else "pandas")
    from ferrobot.cli import main
    from ferrobot.envs.replay import load_episodes

    ds = tmp_path / "ds"
    args = ["generate", "--episodes", "2", "--seed", "3", "--out", str(ds), "--format", fmt]
    assert main([*args, "--cameras", "scene:32x24", "--workers", "1", "--quiet"]) == 0
    if fmt == "hdf5":
        import h5py

        with h5py.File(ds / "dataset.hdf5") as f:
            recorded = [bool(f["data"][f"demo_{i}"].attrs["success"]) for i in range(2)]
            n_actions = [f["data"][f"demo_{i}"]["actions"].shape[0] for i in range(2)]
    else:
        import pyarrow.parquet as pq

        rows = pq.read_table(next((ds / "meta" / "episodes").rglob("*.parquet"))).to_pylist()
        recorded = [bool(r["success"]) for r in sorted(rows, key=lambda r: r["episode_index"])]
        n_actions = [int(r["length"]) for r in sorted(rows, key=lambda r: r["episode_index"])]
    eps = load_episodes(ds)
    assert [len(e.actions) for e in eps] == n_actions
    out = tmp_path / "eval"
    rc = main(["evaluate", "--policy", f"replay:{ds}", "--episodes", "2", "--out", str(out), "--quiet"])
    assert rc == 0
    recs = [json.loads(line) for line in (out / "episodes.jsonl").read_text().splitlines()]
    assert [r["success"] for r in sorted(recs, key=lambda r: r["episode"])] == recorded


def test_user_robot_model_and_start_noise():
    from ferrobot.pipeline.scene import HOME

    model = ferrobot.robots.panda()
    env = make("ferrobot/Lift-v0", robot=model, init_noise=0.05)
    assert env.unwrapped.model is model
    q1 = env.reset(seed=4)[0]["observation.state"]
    q2 = env.reset(seed=4)[0]["observation.state"]
    q3 = env.reset(seed=5)[0]["observation.state"]
    np.testing.assert_array_equal(q1, q2)
    assert not np.array_equal(q1, q3)
    dev = np.abs(q1[:7] - HOME[:7])
    assert dev.max() <= 0.05 + 2e-3 and dev.max() > 1e-3  # the arm settles within ~1 mrad of its noisy start
    with pytest.raises(InvalidArgumentError, match="robot"):
        make(robot="ur5")
    with pytest.raises(InvalidArgumentError, match="cameras"):
        make(obs_mode="rgb", cameras=["ceiling"])


def test_spaces_match_the_dataset_features_name_for_name():
    """Every observation feature the dataset recorder declares (ferrobot.control.features) is in the
    observation space with its shape and dtype, and the joint_pos action space has the recorded action's."""
    from ferrobot.control import features

    env = make(obs_mode="rgbd", segmentation=True, cameras=["scene:32x24", "wrist:16x12"])
    env.reset(seed=0)
    u = env.unwrapped
    feats = features(u.robot, u.stepper, u.cameras, segmentation=True)
    dtypes = {"float32": np.float32, "video": np.uint8, "depth": np.float32, "segmentation": np.int32}
    space = env.observation_space.spaces
    obs_feats = {k: f for k, f in feats.items() if k.startswith("observation.")}
    assert set(obs_feats) == set(space) - {"observation.environment_state"}
    for k, f in obs_feats.items():
        assert space[k].shape == tuple(f["shape"]) and space[k].dtype == dtypes[f["dtype"]], k
    assert env.action_space.shape == tuple(feats["action"]["shape"]) and env.action_space.dtype == np.float32


def test_ur5e_with_its_2f85_as_an_environment():
    """``robot="ur5e"``: Gymnasium's checker passes, the state is the UR5e's 6 joints + the 2F-85's driver, the
    opening starts at the 2F-85's 85 mm stroke, the wrist camera rides on the gripper, ee_pose is its TCP (hand
    FK + the TCP offset, computed here), and the scripted expert reaches a goal."""
    g = ferrobot.Gripper.robotiq_2f85()
    env = make("ferrobot/Reach-v0", robot="ur5e", obs_mode="rgb", cameras=["scene:32x24", "wrist:16x12"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(env.unwrapped)
    obs, _ = env.reset(seed=0)
    u = env.unwrapped
    assert obs["observation.state"].shape == (7,) and u.model.dof_names[-1] == "finger_joint"
    assert obs["observation.gripper_opening"][0] == pytest.approx(0.085, abs=1e-3)
    assert u.gripper.hand_link == g.hand_link
    hand = u.model.fk(u.robot.joint_positions, link=g.hand_link)
    np.testing.assert_allclose(obs["observation.ee_pose"][:3], hand[:3, 3] + hand[:3, :3] @ g.tcp, atol=1e-6)
    s = evaluate("ferrobot/Reach-v0", ExpertPolicy, 1, seed=0, progress=False, env_kwargs={"robot": "ur5e"})
    assert s["successes"] == 1, s
