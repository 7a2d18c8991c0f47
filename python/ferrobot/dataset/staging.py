"""Per-episode staging: an episode is written into a private temporary directory while it runs, then
published by one ``rename`` into ``<out>/.ferrobot/episodes/<episode>``. A published episode is complete by
construction; a half-written one is never visible (a killed worker leaves only a temporary directory, removed
at the next run). Publishing an episode that is already there (a retried task) keeps the first copy: both
copies are identical, since an episode depends only on its seed.

Layout of a staged LeRobot episode (``ep-000007/``): ``frames.parquet`` (one row per control step, the
low-dimensional features), ``<video key>.mp4`` per RGB stream (H.264, yuv420p), ``<depth key>.mp4`` per depth
stream (FFV1, gray16le millimetres: lossless), ``<segmentation key>.mp4`` per segmentation stream (FFV1,
gray16le label ids: lossless), ``episode.json`` (task, success, stages, seed, randomisation,
per-feature statistics). A staged HDF5 episode is ``episode.hdf5`` (one robomimic ``demo`` group) plus
``episode.json``.
"""

from __future__ import annotations

import json
import os
import shutil
import uuid
from pathlib import Path

import numpy as np

__all__ = [
    "LeRobotEpisodeWriter",
    "Hdf5EpisodeWriter",
    "publish",
    "DEPTH_SCALE",
    "depth_to_mm",
    "mm_to_depth",
    "labels_to_u16",
]

#: Depth in stored videos: uint16 millimetres (1 mm resolution, 0 = no reading, up to 65.535 m).
DEPTH_SCALE = 1000.0
#: Codec settings of RGB streams (H.264 in MP4, yuv420p, every episode starting with a key frame).
RGB_CODEC = "libx264"
RGB_PIX_FMT = "yuv420p"
RGB_CRF = 18
DEPTH_CODEC = "ffv1"
DEPTH_PIX_FMT = "gray16le"
#: Segmentation streams: the label ids of ``World.segmentation_labels`` (0 = background) as uint16, FFV1 gray16le.
SEG_CODEC = "ffv1"
SEG_PIX_FMT = "gray16le"
#: Largest segmentation id a LeRobot segmentation stream holds (ids are numbered from 1 in creation order).
SEG_MAX_ID = 65535

LOWDIM_KEYS = (
    "observation.state",
    "observation.velocity",
    "observation.ee_pose",
    "observation.gripper_opening",
    "action",
    "action.ee_pose",
)


def depth_to_mm(depth: np.ndarray) -> np.ndarray:
    """Metres (0 = no reading) -> uint16 millimetres, rounded; depths beyond 65.535 m become 0 (no reading)."""
    mm = np.rint(np.asarray(depth, dtype=np.float64) * DEPTH_SCALE)
    mm[(mm > 65535) | ~np.isfinite(mm)] = 0
    return mm.astype(np.uint16)


def mm_to_depth(mm: np.ndarray) -> np.ndarray:
    return np.asarray(mm, dtype=np.float32) / np.float32(DEPTH_SCALE)


def labels_to_u16(seg: np.ndarray) -> np.ndarray:
    """Segmentation ids -> uint16, exactly; raises InvalidArgumentError when an id is outside [0, 65535] (a world with
    more than 65,535 labelled bodies and links) rather than storing a wrong label."""
    seg = np.asarray(seg)
    if seg.size and (int(seg.min()) < 0 or int(seg.max()) > SEG_MAX_ID):
        from ..errors import InvalidArgumentError

        raise InvalidArgumentError(
            f"segmentation: ids must be in [0, {SEG_MAX_ID}] to be stored as uint16 video, "
            f"got [{int(seg.min())}, {int(seg.max())}]"
        )
    return seg.astype(np.uint16)


def publish(tmp: Path, final: Path) -> bool:
    """Renames ``tmp`` to ``final`` (atomic on one file system). Returns False, removing ``tmp``, when
    ``final`` already exists (the episode was published by an earlier attempt)."""
    try:
        os.rename(tmp, final)
        return True
    except OSError:
        if final.exists():
            shutil.rmtree(tmp, ignore_errors=True)
            return False
        raise


def tmp_dir(root: Path, name: str) -> Path:
    d = root / f"{name}.{os.getpid()}.{uuid.uuid4().hex[:8]}"
    d.mkdir(parents=True)
    return d


class _Stats:
    """Running min, max, sum and sum of squares per component (float64)."""

    def __init__(self):
        self.n = 0
        self.min = self.max = self.sum = self.sq = None

    def add(self, x: np.ndarray, axis=None) -> None:
        x = np.asarray(x, dtype=np.float64)
        if axis is None:
            mn, mx, s, q, n = x, x, x, x * x, 1
        else:
            mn, mx = x.min(axis=axis), x.max(axis=axis)
            s, q = x.sum(axis=axis), (x * x).sum(axis=axis)
            n = int(np.prod([x.shape[a] for a in axis]))
        if self.min is None:
            self.min, self.max, self.sum, self.sq = mn.copy(), mx.copy(), s.copy(), q.copy()
        else:
            self.min, self.max = np.minimum(self.min, mn), np.maximum(self.max, mx)
            self.sum, self.sq = self.sum + s, self.sq + q
        self.n += n

    def to_dict(self) -> dict:
        mean = self.sum / self.n
        std = np.sqrt(np.maximum(self.sq / self.n - mean * mean, 0.0))
        return {
            "min": self.min.tolist(),
            "max": self.max.tolist(),
            "mean": mean.tolist(),
            "std": std.tolist(),
            "count": [self.n],
            "_sum": self.sum.tolist(),
            "_sq": self.sq.tolist(),
        }


class _Video:
    """One MP4 stream; ``kind``: "rgb" (H.264), "depth" (FFV1 uint16 mm) or "segmentation" (FFV1 uint16 ids)."""

    def __init__(self, path: Path, width: int, height: int, fps: int, kind: str):
        import av

        self.av = av
        self.kind = kind
        self.container = av.open(str(path), "w")
        if kind in ("depth", "segmentation"):
            self.stream = self.container.add_stream(DEPTH_CODEC if kind == "depth" else SEG_CODEC, rate=fps)
            self.stream.pix_fmt = DEPTH_PIX_FMT if kind == "depth" else SEG_PIX_FMT
        else:
            self.stream = self.container.add_stream(
                RGB_CODEC, rate=fps, options={"crf": str(RGB_CRF), "preset": "ultrafast", "bf": "0"}
            )
            self.stream.pix_fmt = RGB_PIX_FMT
        self.stream.width, self.stream.height = width, height
        self.stream.thread_count = 1

    def add(self, image: np.ndarray) -> None:
        if self.kind == "depth":
            frame = self.av.VideoFrame.from_ndarray(depth_to_mm(image), format="gray16le")
        elif self.kind == "segmentation":
            frame = self.av.VideoFrame.from_ndarray(labels_to_u16(image), format="gray16le")
        else:
            frame = self.av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")
        for p in self.stream.encode(frame):
            self.container.mux(p)

    def close(self) -> None:
        for p in self.stream.encode():
            self.container.mux(p)
        self.container.close()


def _video_kind(key: str) -> str | None:
    for prefix, kind in (
        ("observation.images.", "rgb"),
        ("observation.depth.", "depth"),
        ("observation.segmentation.", "segmentation"),
    ):
        if key.startswith(prefix):
            return kind
    return None


class LeRobotEpisodeWriter:
    """Streams one episode's frames into a temporary directory (videos encoded as frames arrive)."""

    def __init__(self, staging: Path, name: str, fps: int):
        self.staging, self.name, self.fps = Path(staging), name, int(fps)
        self.dir = tmp_dir(self.staging / "tmp", name)
        self.videos: dict[str, _Video] = {}
        self.cols: dict[str, list] = {k: [] for k in LOWDIM_KEYS}
        self.stats: dict[str, _Stats] = {}
        self.stages: list[str] = []
        self.n = 0

    def __call__(self, frame: dict) -> None:
        for key, value in frame.items():
            kind = _video_kind(key)
            if kind is not None:
                if key not in self.videos:
                    h, w = value.shape[:2]
                    self.videos[key] = _Video(self.dir / f"{key}.mp4", w, h, self.fps, kind)
                self.videos[key].add(value)
                if kind == "segmentation":
                    continue  # label ids: min/max/mean of ids mean nothing, no stats
                st = self.stats.setdefault(key, _Stats())
                if kind == "rgb":
                    st.add(value.reshape(-1, 3)[::16] / 255.0, axis=(0,))  # every 16th pixel: per-channel stats
                else:
                    st.add(value.reshape(-1, 1)[::16], axis=(0,))
            elif key in self.cols:
                self.cols[key].append(np.asarray(value, dtype=np.float32))
                self.stats.setdefault(key, _Stats()).add(value)
        self.stages.append(frame.get("stage", ""))
        self.n += 1

    def finish(self, meta: dict) -> Path:
        """Closes the streams, writes ``frames.parquet`` and ``episode.json``, publishes; returns the
        published directory."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        for v in self.videos.values():
            v.close()
        arrays, names = [], []
        for key, rows in self.cols.items():
            a = np.stack(rows) if rows else np.zeros((0, 1), np.float32)
            if a.shape[1] == 1:
                arrays.append(pa.array(a[:, 0], type=pa.float32()))
            else:
                arrays.append(pa.FixedSizeListArray.from_arrays(pa.array(a.reshape(-1), type=pa.float32()), a.shape[1]))
            names.append(key)
        pq.write_table(pa.Table.from_arrays(arrays, names=names), self.dir / "frames.parquet")
        meta = {
            **meta,
            "length": self.n,
            "stats": {k: s.to_dict() for k, s in self.stats.items()},
            "video_keys": sorted(self.videos),
        }
        (self.dir / "episode.json").write_text(json.dumps(meta))
        final = self.staging / "episodes" / self.name
        publish(self.dir, final)
        return final

    def abort(self) -> None:
        for v in self.videos.values():
            try:
                v.container.close()
            except Exception:
                pass
        shutil.rmtree(self.dir, ignore_errors=True)


class Hdf5EpisodeWriter:
    """Streams one episode into a temporary robomimic-style ``episode.hdf5`` (group ``demo``)."""

    def __init__(self, staging: Path, name: str, fps: int, compression: str | None = "lzf"):
        import h5py

        self.staging, self.name = Path(staging), name
        self.dir = tmp_dir(self.staging / "tmp", name)
        self.file = h5py.File(self.dir / "episode.hdf5", "w")
        self.demo = self.file.create_group("demo")
        self.obs = self.demo.create_group("obs")
        self.compression = compression
        self.ds: dict = {}
        self.n = 0

    def _append(self, group, key: str, value: np.ndarray) -> None:
        value = np.asarray(value)
        ds = self.ds.get((group.name, key))
        if ds is None:
            big = value.ndim >= 2
            ds = group.create_dataset(
                key,
                shape=(0, *value.shape),
                maxshape=(None, *value.shape),
                dtype=value.dtype,
                chunks=(1 if big else 256, *value.shape),
                compression=self.compression if big else None,
            )
            self.ds[(group.name, key)] = ds
        ds.resize(self.n + 1, axis=0)
        ds[self.n] = value

    def __call__(self, frame: dict) -> None:
        for key, value in frame.items():
            if key.startswith("observation."):
                self._append(self.obs, key[len("observation.") :], value)
        self._append(self.demo, "actions", frame["action"])
        self._append(self.demo, "actions_ee_pose", frame["action.ee_pose"])
        self._append(self.demo, "states", frame["state"])
        self.n += 1

    def finish(self, meta: dict) -> Path:
        import json as _json

        n = self.n
        rewards = np.zeros(n, np.float64)
        dones = np.zeros(n, np.int64)
        if n:
            dones[-1] = 1
            rewards[-1] = 1.0 if meta.get("success") else 0.0
        self.demo.create_dataset("rewards", data=rewards)
        self.demo.create_dataset("dones", data=dones)
        self.demo.attrs["num_samples"] = n
        self.demo.attrs["model_file"] = _json.dumps(meta.get("scene", {}))
        self.file.close()
        (self.dir / "episode.json").write_text(json.dumps({**meta, "length": n}))
        final = self.staging / "episodes" / self.name
        publish(self.dir, final)
        return final

    def abort(self) -> None:
        try:
            self.file.close()
        except Exception:
            pass
        shutil.rmtree(self.dir, ignore_errors=True)
