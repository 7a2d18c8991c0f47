"""``GraspGroup`` and ``Grasp``: graspnetAPI's layout and methods.

A grasp is a row of 17 numbers ``[score, width, height, depth, rotation (9,
row-major), translation (3), object_id]``. The gripper frame is graspnetAPI's:
x is the approach direction (palm to fingertips), y the closing direction
(between the fingers), z = x × y. A point ``p`` of the gripper frame is at
``rotation @ p + translation``; the fingertips reach ``depth`` beyond the
translation along x, the fingers open to ``width`` and are ``height`` tall
along z. ``object_id`` is -1 when unknown.
"""

from __future__ import annotations

import numpy as np

from .._core import grasp_nms, grasp_transform
from ..errors import ShapeError

__all__ = ["Grasp", "GraspGroup", "GRASP_COLUMNS", "PANDA_TCP_OFFSET", "GRASP_TO_PANDA_HAND"]

GRASP_COLUMNS = 17

#: Distance (m) from the Panda's ``panda_hand`` frame to its TCP between the finger pads, along the hand's z.
PANDA_TCP_OFFSET = 0.1034

#: Rotation from the grasp frame (x approach, y closing) to the Panda hand frame (z approach, y closing):
#: ``R_hand = R_grasp @ GRASP_TO_PANDA_HAND``; its columns are the hand's axes in grasp coordinates.
GRASP_TO_PANDA_HAND = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])


def _as_array(a) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1 and arr.shape[0] == 0:
        arr = arr.reshape(0, GRASP_COLUMNS)
    if arr.ndim != 2 or arr.shape[1] != GRASP_COLUMNS:
        raise ShapeError(f"grasp array: expected shape (N, {GRASP_COLUMNS}), got {arr.shape}")
    return arr


def _panda_poses(rot: np.ndarray, trans: np.ndarray, depth: np.ndarray, tcp_offset: float) -> np.ndarray:
    out = np.zeros(rot.shape[:-2] + (4, 4))
    out[..., :3, :3] = rot @ GRASP_TO_PANDA_HAND
    approach = rot[..., :, 0]
    out[..., :3, 3] = trans + (depth[..., None] - tcp_offset) * approach
    out[..., 3, 3] = 1.0
    return out


class Grasp:
    """One grasp (a row of a :class:`GraspGroup`)."""

    def __init__(self, grasp_array=None):
        if grasp_array is None:
            grasp_array = np.zeros(GRASP_COLUMNS)
            grasp_array[4:13] = np.eye(3).ravel()
            grasp_array[16] = -1
        a = np.asarray(grasp_array, dtype=np.float64)
        if a.shape != (GRASP_COLUMNS,):
            raise ShapeError(f"grasp: expected {GRASP_COLUMNS} values, got shape {a.shape}")
        self.grasp_array = a.copy()

    score = property(lambda self: float(self.grasp_array[0]), doc="Quality in (0, 1].")
    width = property(lambda self: float(self.grasp_array[1]), doc="Finger opening (m).")
    height = property(lambda self: float(self.grasp_array[2]), doc="Finger size along z (m).")
    depth = property(lambda self: float(self.grasp_array[3]), doc="Fingertip depth beyond the translation (m).")
    rotation_matrix = property(lambda self: self.grasp_array[4:13].reshape(3, 3).copy(), doc="Gripper axes (3, 3).")
    translation = property(lambda self: self.grasp_array[13:16].copy(), doc="Grasp centre (3,).")
    object_id = property(lambda self: int(self.grasp_array[16]), doc="Segmentation id, -1 when unknown.")

    def to_panda_hand(self, tcp_offset: float = PANDA_TCP_OFFSET) -> np.ndarray:
        """4x4 pose of the Panda's ``panda_hand`` frame for this grasp (see :meth:`GraspGroup.to_panda_hand`)."""
        return _panda_poses(self.rotation_matrix, self.translation, np.asarray(self.depth), tcp_offset)

    def __repr__(self) -> str:
        t = np.array2string(self.translation, precision=4)
        return f"Grasp(score={self.score:.4f}, width={self.width:.4f}, depth={self.depth:.4f}, translation={t})"


class GraspGroup:
    """An ordered group of grasps, as graspnetAPI's ``GraspGroup`` (float64 inside; :meth:`to_array` is float32)."""

    def __init__(self, grasp_group_array=None):
        if grasp_group_array is None:
            grasp_group_array = np.zeros((0, GRASP_COLUMNS))
        self.grasp_group_array = _as_array(grasp_group_array).copy()

    def __len__(self) -> int:
        return self.grasp_group_array.shape[0]

    def __getitem__(self, index):
        """An int gives a :class:`Grasp`; a slice, index list or boolean mask gives a :class:`GraspGroup`."""
        if isinstance(index, (int, np.integer)):
            return Grasp(self.grasp_group_array[index])
        return GraspGroup(self.grasp_group_array[index])

    def __iter__(self):
        return (Grasp(row) for row in self.grasp_group_array)

    def __repr__(self) -> str:
        best = f", best score {self.scores.max():.4f}" if len(self) else ""
        return f"GraspGroup({len(self)} grasps{best})"

    @property
    def scores(self) -> np.ndarray:
        """(N,) scores."""
        return self.grasp_group_array[:, 0].copy()

    @property
    def widths(self) -> np.ndarray:
        """(N,) finger openings (m)."""
        return self.grasp_group_array[:, 1].copy()

    @property
    def heights(self) -> np.ndarray:
        """(N,) finger heights (m)."""
        return self.grasp_group_array[:, 2].copy()

    @property
    def depths(self) -> np.ndarray:
        """(N,) fingertip depths (m)."""
        return self.grasp_group_array[:, 3].copy()

    @property
    def rotation_matrices(self) -> np.ndarray:
        """(N, 3, 3) gripper orientations (columns: approach x, closing y, z)."""
        return self.grasp_group_array[:, 4:13].reshape(-1, 3, 3).copy()

    @property
    def translations(self) -> np.ndarray:
        """(N, 3) grasp centres."""
        return self.grasp_group_array[:, 13:16].copy()

    @property
    def object_ids(self) -> np.ndarray:
        """(N,) int32 object ids (-1 when unknown)."""
        return self.grasp_group_array[:, 16].astype(np.int32)

    def to_array(self, dtype=np.float32) -> np.ndarray:
        """(N, 17) array ``[score, width, height, depth, rotation (9), translation (3), object_id]``, float32."""
        return self.grasp_group_array.astype(dtype)

    def sort_by_score(self, reverse: bool = False) -> GraspGroup:
        """Sorts in place, best first (worst first with ``reverse``); returns ``self``."""
        order = np.argsort(-self.grasp_group_array[:, 0], kind="stable")
        if reverse:
            order = order[::-1]
        self.grasp_group_array = self.grasp_group_array[order]
        return self

    def nms(self, translation_thresh: float = 0.03, rotation_thresh: float = 30.0 / 180.0 * np.pi) -> GraspGroup:
        """A new group without grasps within ``translation_thresh`` m and ``rotation_thresh`` rad of a better one.

        A half turn about the approach axis (fingers swapped) counts as the same grasp. Best first.
        """
        if len(self) == 0:
            return GraspGroup()
        keep = grasp_nms(self.grasp_group_array, float(translation_thresh), float(rotation_thresh))
        return GraspGroup(self.grasp_group_array[keep])

    def add(self, other) -> GraspGroup:
        """Appends a :class:`Grasp` or a :class:`GraspGroup`; returns ``self``."""
        rows = other.grasp_array[None] if isinstance(other, Grasp) else other.grasp_group_array
        self.grasp_group_array = np.concatenate([self.grasp_group_array, rows])
        return self

    def transform(self, pose) -> GraspGroup:
        """A new group with every grasp moved by ``pose`` (4x4 or ``[x, y, z, qw, qx, qy, qz]``)."""
        if len(self) == 0:
            return GraspGroup()
        return GraspGroup(grasp_transform(self.grasp_group_array, pose))

    def to_panda_hand(self, tcp_offset: float = PANDA_TCP_OFFSET) -> np.ndarray:
        """(N, 4, 4) poses of the Panda's ``panda_hand`` frame, in the grasps' frame.

        The hand approaches along its z and closes along its y: ``R_hand = R @ GRASP_TO_PANDA_HAND``. It is
        placed so that its TCP (``tcp_offset`` along the hand's z; 0.1034 m for Franka's ``panda_hand_tcp``)
        is at the fingertip centre ``translation + depth * approach``. Open the fingers to ``widths``.
        """
        return _panda_poses(self.rotation_matrices, self.translations, self.depths, tcp_offset)

    def gripper_lines(
        self, finger_depth: float = 0.05, finger_width: float = 0.01, approach_distance: float = 0.03
    ) -> np.ndarray:
        """(N, 36, 2, 3) line segments outlining each hand, for drawing (e.g. matplotlib's ``Line3DCollection``).

        The 12 edges of each of the hand's three boxes (left finger, right finger, palm with the approach
        corridor), as the detector models them: fingers ``finger_depth`` long ending ``depth`` beyond the
        translation, ``finger_width`` thick, ``height`` tall; the palm ``finger_width`` thick behind them and
        the corridor ``approach_distance`` further back. Defaults match the detector's defaults.
        """
        n = len(self)
        w, h, d = self.widths, self.heights, self.depths
        half, outer, hz = w / 2, w / 2 + finger_width, h / 2
        base = d - finger_depth
        back = base - finger_width - approach_distance
        boxes = [
            ((base, -outer, -hz), (d, -half, hz)),
            ((base, half, -hz), (d, outer, hz)),
            ((back, -outer, -hz), (base, outer, hz)),
        ]
        edges = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
        out = np.zeros((n, 36, 2, 3))
        R, t = self.rotation_matrices, self.translations
        for k, (lo, hi) in enumerate(boxes):
            lo = np.stack(lo, -1)
            hi = np.stack(hi, -1)
            corners = np.stack([np.where([(c >> i) & 1 for i in range(3)], hi, lo) for c in range(8)], 1)
            world = np.einsum("nij,ncj->nci", R, corners) + t[:, None, :]
            for e, (a, b) in enumerate(edges):
                out[:, 12 * k + e, 0] = world[:, a]
                out[:, 12 * k + e, 1] = world[:, b]
        return out

    def to_dicts(self) -> list[dict]:
        """AnyGrasp-server style dicts: ``translation``, ``rotation_matrix``, ``depth``, ``width``, ``score``,
        ``height``, ``object_id``."""
        return [
            {
                "translation": row[13:16].tolist(),
                "rotation_matrix": row[4:13].reshape(3, 3).tolist(),
                "depth": float(row[3]),
                "width": float(row[1]),
                "score": float(row[0]),
                "height": float(row[2]),
                "object_id": int(row[16]),
            }
            for row in self.grasp_group_array
        ]

    @classmethod
    def from_dicts(cls, items: list[dict]) -> GraspGroup:
        """Inverse of :meth:`to_dicts` (``height`` defaults to 0.02, ``object_id`` to -1)."""
        rows = np.zeros((len(items), GRASP_COLUMNS))
        for i, g in enumerate(items):
            rows[i, 0] = g["score"]
            rows[i, 1] = g["width"]
            rows[i, 2] = g.get("height", 0.02)
            rows[i, 3] = g["depth"]
            rows[i, 4:13] = np.asarray(g["rotation_matrix"], dtype=np.float64).reshape(9)
            rows[i, 13:16] = g["translation"]
            rows[i, 16] = g.get("object_id", -1)
        return cls(rows)
