"""LeRobot dataset v3.0, built from published (staged) episodes.

Layout (checked against huggingface/lerobot's ``datasets/utils.py`` and ``lerobot_dataset.py``, v3.0)::

    meta/info.json                               codebase_version "v3.0", fps, features, paths, totals
    meta/stats.json                              per-feature min/max/mean/std/count over the dataset
    meta/tasks.parquet                           index: task text, column task_index
    meta/episodes/chunk-000/file-000.parquet     one row per episode: episode_index, tasks, length,
                                                 dataset_from_index/to_index, data/chunk_index, data/file_index,
                                                 videos/<key>/{chunk_index,file_index,from_timestamp,to_timestamp},
                                                 meta/episodes/{chunk_index,file_index}, stats/<feature>/<stat>,
                                                 plus ferrobot's success, seed, stages, randomization,
                                                 segmentation_labels (JSON id -> name) and scene
                                                 (JSON; ``scene_from_dict`` rebuilds the SceneSpec for a replay)
    data/chunk-XXX/file-XXX.parquet              frames of several episodes: the low-dimensional features,
                                                 timestamp, frame_index, episode_index, index, task_index,
                                                 next.reward, next.done
    videos/<key>/chunk-XXX/file-XXX.mp4          RGB streams: H.264 (yuv420p), several episodes per file

**Depth** is stored losslessly as uint16 millimetres (0 = no reading; 1 mm resolution) in FFV1 video
(pixel format gray16le) in MP4 files under ``videos/observation.depth.<camera>/`` with the same chunk/file
and timestamp columns as the RGB streams. LeRobot's loader decodes RGB videos only, so depth streams are
listed in ``info.json`` under ``depth_features`` (not ``features``): ``LeRobotDataset`` loads the dataset
and ignores them; read them with PyAV (``frame.to_ndarray(format="gray16le") / 1000`` gives metres).

**Segmentation** (recorded by default; ``--no-segmentation`` leaves it out) is stored losslessly the same way:
uint16 label ids (the ids of ``World.segmentation_labels``, 0 = background) in FFV1 gray16le MP4 files under
``videos/observation.segmentation.<camera>/``, with chunk/file/timestamp columns like every video. They are
listed in ``info.json`` under ``segmentation_features`` (dtype "uint16"; the id -> name table of each
episode's world is the episode row's ``segmentation_labels`` column, JSON); read them with PyAV
(``frame.to_ndarray(format="gray16le")`` gives the ids). No stats are kept for them (averages of ids mean
nothing). Why beside ``features`` and not in it (checked in lerobot 0.4.4's ``datasets/utils.py`` and
``video_utils.py``): every non-"video"/"image" feature must be a column of the frame parquet files, and
"video" features are decoded to 8-bit RGB tensors scaled to [0, 1], which would not keep 16-bit ids or
millimetres; streams listed outside ``features`` are ignored by ``LeRobotDataset`` and load unchanged with PyAV.

Episodes are assigned to files in episode order; a file is closed once it exceeds ``data_files_size_in_mb`` /
``video_files_size_in_mb``; ``chunks_size`` files per chunk directory.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np

from .staging import DEPTH_CODEC, DEPTH_PIX_FMT, LOWDIM_KEYS, RGB_PIX_FMT, SEG_CODEC, SEG_PIX_FMT

__all__ = ["finalize_lerobot", "CODEBASE_VERSION", "DATA_PATH", "VIDEO_PATH"]

CODEBASE_VERSION = "v3.0"
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
CHUNKS_SIZE = 1000
DATA_FILE_MB = 100
VIDEO_FILE_MB = 200
STATS = ("min", "max", "mean", "std", "count")


class _FileCounter:
    def __init__(self, limit_mb: float):
        self.limit = limit_mb * 1e6
        self.chunk = self.file = 0
        self.size = 0.0
        self.started = False

    def place(self, nbytes: float) -> tuple[int, int]:
        """The (chunk, file) an item of ``nbytes`` goes to."""
        if self.started and self.size >= self.limit:
            self.file += 1
            if self.file >= CHUNKS_SIZE:
                self.chunk, self.file = self.chunk + 1, 0
            self.size = 0.0
        self.started = True
        self.size += nbytes
        return self.chunk, self.file


def _merge_stats(parts: list[dict]) -> dict:
    n = sum(p["count"][0] for p in parts)
    s = np.sum([np.asarray(p["_sum"]) for p in parts], axis=0)
    q = np.sum([np.asarray(p["_sq"]) for p in parts], axis=0)
    mean = s / n
    return {
        "min": np.min([np.asarray(p["min"]) for p in parts], axis=0).tolist(),
        "max": np.max([np.asarray(p["max"]) for p in parts], axis=0).tolist(),
        "mean": mean.tolist(),
        "std": np.sqrt(np.maximum(q / n - mean * mean, 0.0)).tolist(),
        "count": [int(n)],
    }


def _image_stats(st: dict) -> dict:
    """Per-channel image statistics in LeRobot's (C, 1, 1) layout."""
    return {k: (v if k == "count" else [[[x]] for x in v]) for k, v in st.items() if not k.startswith("_")}


def _concat_videos(sources: list[Path], dest: Path, fps: int) -> None:
    """Concatenates MP4s of one stream without re-encoding: packets copied, timestamps shifted by the frames
    before them (every source starts with a key frame and has no B-frames)."""
    import av

    dest.parent.mkdir(parents=True, exist_ok=True)
    out = av.open(str(dest), "w")
    ostream = None
    offset = 0
    for src in sources:
        inp = av.open(str(src))
        istream = inp.streams.video[0]
        if ostream is None:
            ostream = out.add_stream_from_template(istream)
        count = 0
        last = -1
        for packet in inp.demux(istream):
            if packet.dts is None:
                continue
            # Timestamps in frames: the input's time base is 1/fps-based; rescale into the output's.
            pts = int(round(float(packet.pts * istream.time_base) * fps)) if packet.pts is not None else None
            dts = int(round(float(packet.dts * istream.time_base) * fps))
            packet.stream = ostream
            if pts is not None:
                packet.pts = int(round((pts + offset) / fps / ostream.time_base))
                last = max(last, pts)
            packet.dts = int(round((dts + offset) / fps / ostream.time_base))
            out.mux(packet)
            count += 1
        frames = istream.frames or (last + 1)
        offset += frames
        inp.close()
    out.close()


def finalize_lerobot(root: Path, episode_dirs: list[Path], info_extra: dict, work: Path, fault=None) -> None:
    """Builds the v3.0 dataset from ``episode_dirs`` (in episode order) into ``work`` (a fresh directory),
    then moves ``meta``, ``data`` and ``videos`` into ``root``."""
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    fps = int(info_extra["fps"])
    metas = [json.loads((d / "episode.json").read_text()) for d in episode_dirs]
    tasks: dict[str, int] = {}
    for m in metas:
        tasks.setdefault(m["task"], len(tasks))
    video_keys = sorted(
        k for k, f in info_extra["features"].items() if f["dtype"] in ("video", "depth", "segmentation")
    )
    rgb_keys = [k for k in video_keys if k.startswith("observation.images.")]
    depth_keys = [k for k in video_keys if k.startswith("observation.depth.")]

    data_files = _FileCounter(DATA_FILE_MB)
    video_files = {k: _FileCounter(VIDEO_FILE_MB) for k in video_keys}
    data_groups: dict[tuple[int, int], list] = {}
    video_groups: dict[str, dict[tuple[int, int], list[Path]]] = {k: {} for k in video_keys}
    video_time: dict[str, dict[tuple[int, int], float]] = {k: {} for k in video_keys}
    rows = []
    index = 0
    for ep, (d, m) in enumerate(zip(episode_dirs, metas, strict=True)):
        n = m["length"]
        table = pq.read_table(d / "frames.parquet")
        ts = (np.arange(n) / fps).astype(np.float32)
        reward = np.zeros(n, np.float32)
        done = np.zeros(n, bool)
        if n:
            done[-1] = True
            reward[-1] = 1.0 if m["success"] else 0.0
        table = (
            table.append_column("timestamp", pa.array(ts))
            .append_column("frame_index", pa.array(np.arange(n, dtype=np.int64)))
            .append_column("episode_index", pa.array(np.full(n, ep, np.int64)))
            .append_column("index", pa.array(np.arange(index, index + n, dtype=np.int64)))
            .append_column("task_index", pa.array(np.full(n, tasks[m["task"]], np.int64)))
            .append_column("next.reward", pa.array(reward))
            .append_column("next.done", pa.array(done))
        )
        chunk, file = data_files.place(table.nbytes)
        data_groups.setdefault((chunk, file), []).append(table)
        row = {
            "episode_index": ep,
            "tasks": [m["task"]],
            "length": n,
            "data/chunk_index": chunk,
            "data/file_index": file,
            "dataset_from_index": index,
            "dataset_to_index": index + n,
        }
        for k in video_keys:
            src = d / f"{k}.mp4"
            vc, vf = video_files[k].place(src.stat().st_size)
            start = video_time[k].get((vc, vf), 0.0)
            video_groups[k].setdefault((vc, vf), []).append(src)
            video_time[k][(vc, vf)] = start + n / fps
            row[f"videos/{k}/chunk_index"] = vc
            row[f"videos/{k}/file_index"] = vf
            row[f"videos/{k}/from_timestamp"] = start
            row[f"videos/{k}/to_timestamp"] = start + n / fps
        row["meta/episodes/chunk_index"] = 0
        row["meta/episodes/file_index"] = 0
        for key, st in m["stats"].items():
            st = _image_stats(st) if key in rgb_keys else {k: v for k, v in st.items() if not k.startswith("_")}
            for s in STATS:
                row[f"stats/{key}/{s}"] = st[s]
        row["success"] = bool(m["success"])
        row["seed"] = int(m["seed"])
        row["stages"] = json.dumps(m["stages"])
        row["randomization"] = json.dumps(m.get("randomization", {}))
        row["scene"] = json.dumps(m.get("scene", {}))
        row["segmentation_labels"] = json.dumps(m.get("segmentation_labels", {}))
        rows.append(row)
        index += n

    for (chunk, file), tables in data_groups.items():
        p = work / DATA_PATH.format(chunk_index=chunk, file_index=file)
        p.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(pa.concat_tables(tables), p)
    for k in video_keys:
        for (chunk, file), srcs in video_groups[k].items():
            _concat_videos(srcs, work / VIDEO_PATH.format(video_key=k, chunk_index=chunk, file_index=file), fps)

    ep_path = work / EPISODES_PATH.format(chunk_index=0, file_index=0)
    ep_path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(pa.Table.from_pylist(rows), ep_path)
    task_df = pd.DataFrame({"task_index": list(tasks.values())}, index=pd.Index(list(tasks), name="task"))
    task_df.to_parquet(work / "meta" / "tasks.parquet")

    stats = {}
    keys = [k for k in (*LOWDIM_KEYS, *rgb_keys, *depth_keys)]
    for key in keys:
        parts = [m["stats"][key] for m in metas if key in m["stats"]]
        if parts:
            merged = _merge_stats(parts)
            stats[key] = _image_stats(merged) if key in rgb_keys else merged
    (work / "meta" / "stats.json").write_text(json.dumps(stats, indent=2))

    features = dict(info_extra["features"])
    scalar = {"dtype": "float32", "shape": [1], "names": None}
    for key in rgb_keys:
        f = features[key]
        h, w = f["shape"][:2]
        features[key] = {
            "dtype": "video",
            "shape": [h, w, 3],
            "names": ["height", "width", "channels"],
            "info": {
                "video.height": h,
                "video.width": w,
                "video.codec": "h264",
                "video.pix_fmt": RGB_PIX_FMT,
                "video.is_depth_map": False,
                "video.fps": fps,
                "video.channels": 3,
                "has_audio": False,
            },
        }
    depth_features = {}
    for key in depth_keys:
        f = features.pop(key)
        depth_features[key] = {
            **f,
            "dtype": "uint16",
            "unit": "mm",
            "scale": 1000.0,
            "no_reading": 0,
            "info": {"video.codec": DEPTH_CODEC, "video.pix_fmt": DEPTH_PIX_FMT, "video.fps": fps, "lossless": True},
        }
    segmentation_features = {}
    for key in [k for k in video_keys if k.startswith("observation.segmentation.")]:
        f = features.pop(key)
        segmentation_features[key] = {
            **f,
            "dtype": "uint16",
            "meaning": "segmentation label id (World.segmentation_labels), 0 = background",
            "background": 0,
            "info": {"video.codec": SEG_CODEC, "video.pix_fmt": SEG_PIX_FMT, "video.fps": fps, "lossless": True},
        }
    features.update(
        {
            "timestamp": scalar,
            "frame_index": {"dtype": "int64", "shape": [1], "names": None},
            "episode_index": {"dtype": "int64", "shape": [1], "names": None},
            "index": {"dtype": "int64", "shape": [1], "names": None},
            "task_index": {"dtype": "int64", "shape": [1], "names": None},
            "next.reward": scalar,
            "next.done": {"dtype": "bool", "shape": [1], "names": None},
        }
    )
    info = {
        "codebase_version": CODEBASE_VERSION,
        "robot_type": info_extra.get("robot_type", "panda"),
        "total_episodes": len(metas),
        "total_frames": index,
        "total_tasks": len(tasks),
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": DATA_FILE_MB,
        "video_files_size_in_mb": VIDEO_FILE_MB,
        "fps": fps,
        "splits": {"train": f"0:{len(metas)}"},
        "data_path": DATA_PATH,
        "video_path": VIDEO_PATH,
        "features": features,
        "depth_features": depth_features,
        "segmentation_features": segmentation_features,
        "ferrobot": info_extra.get("ferrobot", {}),
    }
    (work / "meta" / "info.json").write_text(json.dumps(info, indent=2))
    for k, sub in enumerate(("meta", "data", "videos")):
        if k == 1 and fault is not None:
            fault()  # test hook: a kill between the moves
        if (root / sub).exists():
            shutil.rmtree(root / sub)
        if (work / sub).exists():
            (work / sub).rename(root / sub)
