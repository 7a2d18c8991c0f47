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
from .._tessellate import BOX_FACES as _BOX_FACES
from ..errors import InvalidArgumentError, NonFiniteError, ShapeError

__all__ = ["Grasp", "GraspGroup", "GRASP_COLUMNS", "PANDA_TCP_OFFSET", "GRASP_TO_PANDA_HAND"]

GRASP_COLUMNS = 17

#: Distance (m) from the Panda's ``panda_hand`` frame to its TCP between the finger pads, along the hand's z.
PANDA_TCP_OFFSET = 0.1034

#: Rotation from the grasp frame (x approach, y closing) to the Panda hand frame (z approach, y closing):
#: ``R_hand = R_grasp @ GRASP_TO_PANDA_HAND``; its columns are the hand's axes in grasp coordinates.
GRASP_TO_PANDA_HAND = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])


class _instance_or_class:
    """A method bound to the instance when called on one, else to the class (graspnetAPI's ``from_npy``)."""

    def __init__(self, f):
        self.f = f
        self.__doc__ = f.__doc__

    def __get__(self, obj, cls):
        target = cls if obj is None else obj
        return lambda *a, **k: self.f(target, *a, **k)


def _as_array(a) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1 and arr.shape[0] == 0:
        arr = arr.reshape(0, GRASP_COLUMNS)
    if arr.ndim != 2 or arr.shape[1] != GRASP_COLUMNS:
        raise ShapeError(f"grasp array: expected shape (N, {GRASP_COLUMNS}), got {arr.shape}")
    return arr


def _warn_panda_hand() -> None:
    import warnings

    warnings.warn(
        "to_panda_hand() is deprecated: use to_hand(ferrobot.Gripper.panda_hand()) (any ferrobot.Gripper works)",
        DeprecationWarning,
        stacklevel=3,
    )


def _panda_poses(rot: np.ndarray, trans: np.ndarray, depth: np.ndarray, tcp_offset: float) -> np.ndarray:
    out = np.zeros(rot.shape[:-2] + (4, 4))
    out[..., :3, :3] = rot @ GRASP_TO_PANDA_HAND
    approach = rot[..., :, 0]
    out[..., :3, 3] = trans + (depth[..., None] - tcp_offset) * approach
    out[..., 3, 3] = 1.0
    return out


def _hand_poses(rot: np.ndarray, trans: np.ndarray, depth: np.ndarray, gripper) -> np.ndarray:
    """Poses of ``gripper``'s hand link for grasps: the grasp frame moved to the fingertips, then the gripper's
    ``grasp_to_hand`` transform (its TCP on the fingertip centre, its approach and closing axes on x and y)."""
    if not hasattr(gripper, "grasp_to_hand"):
        raise InvalidArgumentError(f"gripper: expected a ferrobot.Gripper, got {type(gripper).__name__}")
    tip = np.zeros(rot.shape[:-2] + (4, 4))
    tip[..., :3, :3] = rot
    tip[..., :3, 3] = trans + depth[..., None] * rot[..., :, 0]
    tip[..., 3, 3] = 1.0
    return tip @ np.asarray(gripper.grasp_to_hand())


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
        """4x4 pose of the Panda's ``panda_hand`` frame for this grasp (see :meth:`GraspGroup.to_panda_hand`).

        Deprecated: use :meth:`to_hand` with ``ferrobot.Gripper.panda_hand()`` (or any gripper)."""
        _warn_panda_hand()
        return _panda_poses(self.rotation_matrix, self.translation, np.asarray(self.depth), tcp_offset)

    def to_hand(self, gripper) -> np.ndarray:
        """4x4 pose of ``gripper``'s hand link for this grasp (see :meth:`GraspGroup.to_hand`)."""
        return _hand_poses(self.rotation_matrix, self.translation, np.asarray(self.depth), gripper)

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

    def to_hand(self, gripper) -> np.ndarray:
        """(N, 4, 4) poses of ``gripper``'s hand link (a :class:`ferrobot.Gripper`), in the grasps' frame.

        The hand's approach axis goes along the grasp's x and its closing axis along the grasp's y; its TCP
        sits at the fingertip centre ``translation + depth * approach``. Open the fingers to ``widths``
        (``Robot.set_gripper_opening``). ``to_hand(ferrobot.Gripper.panda_hand())`` equals the deprecated
        ``to_panda_hand()``.
        """
        return _hand_poses(self.rotation_matrices, self.translations, self.depths, gripper)

    def to_panda_hand(self, tcp_offset: float = PANDA_TCP_OFFSET) -> np.ndarray:
        """(N, 4, 4) poses of the Panda's ``panda_hand`` frame, in the grasps' frame.

        Deprecated: use :meth:`to_hand` with ``ferrobot.Gripper.panda_hand()`` (or any gripper).

        The hand approaches along its z and closes along its y: ``R_hand = R @ GRASP_TO_PANDA_HAND``. It is
        placed so that its TCP (``tcp_offset`` along the hand's z; 0.1034 m for Franka's ``panda_hand_tcp``)
        is at the fingertip centre ``translation + depth * approach``. Open the fingers to ``widths``.
        """
        _warn_panda_hand()
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
        """Inverse of :meth:`to_dicts`, tolerant of other servers' answers (AnyGrasp Flask servers).

        Required per grasp: ``translation`` (3) and ``rotation_matrix`` (3x3, or ``rotation`` / 9 values).
        Missing fields take :data:`DICT_DEFAULTS`: ``score`` 0 (order kept), ``width`` 0.08 m (the Panda's
        full opening, ferrobot's ``max_width``), ``height`` 0.02 m, ``depth`` 0.02 m (graspnetAPI's defaults),
        ``object_id`` -1. A missing required field raises :class:`ferrobot.errors.InvalidArgumentError`.
        """
        rows = np.zeros((len(items), GRASP_COLUMNS))
        for i, g in enumerate(items):
            if not isinstance(g, dict):
                raise InvalidArgumentError(f"grasp {i}: expected a dict, got {type(g).__name__}")
            rot = g.get("rotation_matrix", g.get("rotation"))
            if rot is None or g.get("translation") is None:
                raise InvalidArgumentError(
                    f"grasp {i}: needs 'translation' and 'rotation_matrix'; got keys {sorted(g)}"
                )
            rows[i, 0] = g.get("score", DICT_DEFAULTS["score"])
            rows[i, 1] = g.get("width", DICT_DEFAULTS["width"])
            rows[i, 2] = g.get("height", DICT_DEFAULTS["height"])
            rows[i, 3] = g.get("depth", DICT_DEFAULTS["depth"])
            rows[i, 4:13] = np.asarray(rot, dtype=np.float64).reshape(9)
            rows[i, 13:16] = np.asarray(g["translation"], dtype=np.float64).reshape(3)
            rows[i, 16] = g.get("object_id", DICT_DEFAULTS["object_id"])
        if not np.all(np.isfinite(rows)):
            raise NonFiniteError("grasps: the answer contains NaN or infinite values")
        return cls(rows)

    # --- graspnetAPI's file and sampling methods (issue 22) ---

    def save_npy(self, npy_file_path) -> None:
        """Saves the (N, 17) float32 array with ``numpy.save`` (graspnetAPI's file format)."""
        np.save(npy_file_path, self.to_array())

    @_instance_or_class
    def from_npy(self_or_cls, npy_file_path):
        """Loads a ``save_npy`` file. As graspnetAPI: ``GraspGroup().from_npy(path)`` fills that group and returns
        it; ``GraspGroup.from_npy(path)`` returns a new group."""
        arr = np.load(npy_file_path, allow_pickle=False)
        if isinstance(self_or_cls, type):
            return self_or_cls(arr)
        self_or_cls.grasp_group_array = _as_array(arr).copy()
        return self_or_cls

    def random_sample(self, numGrasp: int = 20, rng=None) -> GraspGroup:  # noqa: N803 (graspnetAPI's name)
        """A new group of ``numGrasp`` grasps drawn without replacement; ``rng`` a ``numpy.random.Generator`` or
        a seed (default: fresh entropy)."""
        n = int(numGrasp)
        if n < 0 or n > len(self):
            raise InvalidArgumentError(f"numGrasp: expected 0..{len(self)} (the group's size), got {numGrasp}")
        rng = np.random.default_rng(rng)
        return GraspGroup(self.grasp_group_array[rng.permutation(len(self))[:n]])

    def remove(self, index) -> GraspGroup:
        """Removes the grasps at ``index`` (an int, list or boolean mask) in place; returns ``self``."""
        ix = np.asarray(index)
        if ix.dtype == bool:
            if ix.shape != (len(self),):
                raise ShapeError(f"index: a boolean mask needs shape ({len(self)},), got {ix.shape}")
            ix = np.flatnonzero(ix)
        ix = ix.astype(np.int64).ravel()
        if ix.size and (ix.min() < -len(self) or ix.max() >= len(self)):
            raise InvalidArgumentError(f"index: out of range for {len(self)} grasps")
        self.grasp_group_array = np.delete(self.grasp_group_array, ix, axis=0)
        return self

    def to_open3d_geometry_list(self, color=None) -> list:
        """One ``open3d.geometry.TriangleMesh`` per grasp (the hand's fingers and palm as boxes, the outline of
        :meth:`gripper_lines`); needs ``open3d`` (``pip install open3d``)."""
        try:
            import open3d as o3d
        except ImportError as e:
            raise ImportError("to_open3d_geometry_list needs open3d: pip install open3d") from e
        out = []
        for verts, faces in _gripper_meshes(self):
            m = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(verts), o3d.utility.Vector3iVector(faces))
            m.compute_vertex_normals()
            m.paint_uniform_color(list(color) if color is not None else [1.0, 0.0, 0.0])
            out.append(m)
        return out


#: Values ``GraspGroup.from_dicts`` uses for fields a server leaves out.
DICT_DEFAULTS = {"score": 0.0, "width": 0.08, "height": 0.02, "depth": 0.02, "object_id": -1}


def _gripper_meshes(group: GraspGroup, finger_depth=0.05, finger_width=0.01, approach_distance=0.03):
    """Per grasp (vertices (24, 3), faces (36, 3)): the three boxes of :meth:`GraspGroup.gripper_lines`."""
    lines = group.gripper_lines(finger_depth, finger_width, approach_distance)
    for g in lines:
        verts, faces = [], []
        for k in range(3):
            seg = g[12 * k : 12 * k + 12]
            corners = np.zeros((8, 3))
            corners[0], corners[1] = seg[0, 0], seg[0, 1]  # edge 0-1
            corners[2], corners[4] = seg[1, 1], seg[2, 1]  # edges 0-2, 0-4
            corners[3] = seg[3, 1]  # edge 1-3
            corners[5] = seg[4, 1]  # edge 1-5
            corners[6] = seg[6, 1]  # edge 2-6
            corners[7] = seg[7, 1]  # edge 3-7
            verts.append(corners)
            faces.append(_BOX_FACES + 8 * k)
        yield np.concatenate(verts), np.concatenate(faces)
