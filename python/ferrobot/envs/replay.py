"""Replay of recorded episodes: a policy that plays back a dataset episode's actions in its recorded scene.

A recorded episode (``ferrobot generate``) stores its scene (the :class:`~ferrobot.pipeline.SceneSpec` after
randomisation, or the seed and config it is rebuilt from), its actions (``action``: arm joint position
targets + gripper, float32, one per control step) and its outcome. The environment, reset with
``options={"scene": ...}`` (:meth:`ReplayPolicy.reset_options`), builds the same world in the same state,
and :mod:`ferrobot.control` steps it the same way, so the episode replays to the same outcome. The actions
are stored as float32 while the recorder stepped float64 values; Rapier's drives take float32 targets, and
``tests/test_envs.py`` replays a pipeline recording to the recorded simulator state after every action bit
for bit.

The episode's domain randomisation is replayed too: the scene (object colours, masses, frictions, the scene
camera's pose) is in the stored scene, and the rendering draws (the lighting, the wrist camera's mount pose) are
passed as ``options["randomization"]``, so the replayed cameras see what was recorded (``tests/test_dataset.py``
compares the replayed images with the recorded ones). :meth:`ReplayPolicy.env_kwargs` gives the dataset's robot
and gripper, which ``ferrobot evaluate`` uses to make the environment.

``ferrobot evaluate --policy replay:DATASET_DIR`` replays the dataset's episodes in order (evaluation episode
``i`` plays dataset episode ``i``); ``replay:DATASET_DIR:K`` plays episode ``K`` every time.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FileFormatError, InvalidArgumentError

__all__ = ["RecordedEpisode", "ReplayPolicy", "load_episodes"]


@dataclass
class RecordedEpisode:
    """One recorded episode: its scene (a SceneSpec dict), actions (T, A) and recorded outcome."""

    index: int
    scene: dict
    actions: np.ndarray
    success: bool
    control_hz: float = 10.0
    #: The episode's domain randomisation (lighting, wrist camera mount, ...): re-applied on replay.
    randomization: dict = field(default_factory=dict)
    #: The generation config's robot: {"robot", "srdf", "gripper"} (None values: defaults).
    robot: dict = field(default_factory=dict)


def _lerobot(root: Path) -> list[RecordedEpisode]:
    """A LeRobot v3.0 dataset written by ``ferrobot generate``: each episode's scene is its ``scene`` column
    or, in datasets written before that column existed, rebuilt from its seed and the generation config
    (``info.json``'s ``ferrobot``) by the generator's :func:`ferrobot.dataset.generate.episode_spec` and
    checked against the randomisation it recorded."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ..dataset.generate import episode_spec

    info = json.loads((root / "meta" / "info.json").read_text())
    cfg = info.get("ferrobot")
    if not cfg:
        raise FileFormatError(f"{root}: meta/info.json has no 'ferrobot' generation config (not a ferrobot dataset)")
    fps = float(info.get("fps", cfg.get("control_hz", 10)))
    eps = pa.concat_tables(
        [pq.read_table(p) for p in sorted((root / "meta" / "episodes").rglob("*.parquet"))]
    ).to_pylist()
    data = pa.concat_tables(
        [pq.read_table(p, columns=["episode_index", "action"]) for p in sorted((root / "data").rglob("*.parquet"))]
    )
    ep_col = data.column("episode_index").to_numpy()
    actions = np.asarray(data.column("action").to_pylist(), dtype=np.float32)
    robot = _robot_of(cfg)
    out = []
    for row in sorted(eps, key=lambda r: r["episode_index"]):
        i = int(row["episode_index"])
        stored = json.loads(row.get("scene") or "{}")
        recorded = json.loads(row.get("randomization") or "{}")
        if stored:  # datasets that store the scene (the episodes table's ``scene`` column)
            out.append(RecordedEpisode(i, stored, actions[ep_col == i], bool(row["success"]), fps, recorded, robot))
            continue
        spec, rand = episode_spec(cfg, int(row["seed"]))
        if json.loads(json.dumps(rand)) != recorded:
            raise FileFormatError(
                f"{root}: episode {i}: the scene rebuilt from seed {row['seed']} does not match the recorded "
                "randomisation (dataset written by another ferrobot version?)"
            )
        out.append(RecordedEpisode(i, spec.to_dict(), actions[ep_col == i], bool(row["success"]), fps, rand, robot))
    return out


def _robot_of(cfg: dict) -> dict:
    """The robot part of a generation config (``ferrobot generate``'s --robot, --srdf, --gripper)."""
    return {"robot": cfg.get("robot", "panda"), "srdf": cfg.get("srdf"), "gripper": cfg.get("gripper")}


def _hdf5(path: Path) -> list[RecordedEpisode]:
    """A robomimic-layout HDF5 file written by ``ferrobot generate``: ``data/demo_<i>`` with ``actions``, the
    scene as JSON in the ``model_file`` attribute, ``success``; the control rate in ``data``'s ``fps``."""
    import h5py

    out = []
    with h5py.File(path, "r") as f:
        if "data" not in f:
            raise FileFormatError(f"{path}: no 'data' group (not a robomimic-layout file)")
        data = f["data"]
        fps = float(data.attrs.get("fps", 10))
        robot = _robot_of(json.loads(data.attrs.get("ferrobot", "{}")))
        names = sorted((n for n in data.keys() if n.startswith("demo_")), key=lambda n: int(n.split("_")[-1]))
        for n in names:
            g = data[n]
            if "model_file" not in g.attrs:
                raise FileFormatError(f"{path}: {n} has no 'model_file' (the scene) attribute")
            scene = json.loads(g.attrs["model_file"])
            success = bool(g.attrs.get("success", False))
            rand = json.loads(g.attrs.get("randomization", "{}"))
            out.append(
                RecordedEpisode(int(n.split("_")[-1]), scene, np.asarray(g["actions"]), success, fps, rand, robot)
            )
    return out


def load_episodes(path: str | Path) -> list[RecordedEpisode]:
    """The episodes of a recorded dataset: a LeRobot v3 folder (``meta/info.json``) or a robomimic-style
    HDF5 file (or a folder holding ``dataset.hdf5``), as ``ferrobot generate`` writes them."""
    p = Path(path)
    if (p / "meta" / "info.json").exists():
        return _lerobot(p)
    if p.is_dir() and (p / "dataset.hdf5").exists():
        p = p / "dataset.hdf5"
    if p.is_file() and p.suffix in (".hdf5", ".h5"):
        return _hdf5(p)
    raise FileFormatError(f"{path}: not a recorded dataset (no meta/info.json, no .hdf5 file)")


class ReplayPolicy:
    """Plays back recorded actions: episode ``i`` of an evaluation replays ``episodes[i]`` (or always
    ``episodes[fixed]``). After the recorded actions end it holds the last one. :meth:`reset_options`
    gives the environment the recorded scene."""

    def __init__(self, episodes: list[RecordedEpisode], fixed: int | None = None):
        if not episodes:
            raise InvalidArgumentError("episodes: the dataset has no episodes")
        self.episodes = episodes
        self.fixed = fixed
        if fixed is not None and not 0 <= fixed < len(episodes):
            raise InvalidArgumentError(f"episode: expected 0..{len(episodes) - 1}, got {fixed}")
        self.current: RecordedEpisode | None = None
        self.t = 0
        self._hold = None

    @classmethod
    def from_spec(cls, spec: str) -> ReplayPolicy:
        """``"DATASET_DIR"`` or ``"DATASET_DIR:EPISODE"``."""
        path, fixed = spec, None
        head, sep, tail = spec.rpartition(":")
        if sep and tail.isdigit():
            path, fixed = head, int(tail)
        return cls(load_episodes(path), fixed)

    def _episode(self, i: int) -> RecordedEpisode:
        if self.fixed is not None:
            return self.episodes[self.fixed]
        if not 0 <= i < len(self.episodes):
            raise InvalidArgumentError(f"replay: evaluation episode {i} but the dataset has {len(self.episodes)}")
        return self.episodes[i]

    def reset_options(self, episode: int) -> dict:
        """The ``env.reset`` options of evaluation episode ``episode``: the recorded scene and randomisation."""
        self.current = self._episode(episode)
        return {"scene": self.current.scene, "randomization": self.current.randomization}

    def env_kwargs(self) -> dict:
        """``gym.make`` keyword arguments for the recorded robot and gripper (empty: the defaults)."""
        r = self.episodes[0].robot
        out = {}
        if r.get("robot") not in (None, "panda"):
            out["robot"] = r["robot"]
        for k in ("srdf", "gripper"):
            if r.get(k) is not None:
                out[k] = r[k]
        return out

    def reset(self, env=None, **_) -> None:
        if self.current is None:
            raise InvalidArgumentError("replay: reset the environment with reset_options(episode) first")
        if env is not None:
            u = env.unwrapped
            if u.control_mode != "joint_pos":
                raise InvalidArgumentError(f"replay: needs control_mode 'joint_pos', got {u.control_mode!r}")
            if abs(u.control_hz - self.current.control_hz) > 1e-9:
                raise InvalidArgumentError(
                    f"replay: the dataset was recorded at {self.current.control_hz} Hz, the environment runs at "
                    f"{u.control_hz} Hz"
                )
            n = u.action_space.shape[0]
            if len(self.current.actions) and self.current.actions.shape[1] != n:
                raise InvalidArgumentError(
                    f"replay: the dataset's actions have {self.current.actions.shape[1]} entries, the environment's "
                    f"{n} (another robot? make it with {self.env_kwargs() or 'the default robot'})"
                )
        self.t = 0
        self._hold = None if env is None else env.unwrapped.stepper.hold_action().astype(np.float32)

    def act(self, obs=None) -> np.ndarray:
        a = self.current.actions
        if len(a) == 0:  # an episode that failed before moving: hold still
            if self._hold is None:
                raise InvalidArgumentError("replay: the recorded episode has no actions; pass env to reset()")
            return self._hold
        row = a[min(self.t, len(a) - 1)]
        self.t += 1
        return row
