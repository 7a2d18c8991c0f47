"""The grasp HTTP service: a FastAPI app served by uvicorn (``ferrobot serve-grasp``).

Endpoints (the OpenAPI document at ``/openapi.json`` describes each request body):

* ``GET /health``: ``{"status": "ok", "version", "pid"}``.
* ``POST /process``: the JSON body AnyGrasp client code sends: ``colors`` (H x W x 3 nested lists, optional,
  checked and unused), ``depths`` (H x W nested lists), ``fx``, ``fy``, ``cx``, ``cy``, ``scale``; optional
  ``lims`` / ``workspace`` ``[xmin, xmax, ymin, ymax, zmin, zmax]``, ``mask`` (H x W ids or booleans),
  ``object_id``, ``max_grasps`` and ``options`` (detection options, see :data:`OPTION_RANGES`).
  Answers ``{"grasp_groups": [{"translation", "rotation_matrix", "depth", "width", "score", "height",
  "object_id"}]}``, best first, in the camera frame.
* ``POST /process_npz``: the same request as an ``.npz`` archive (``numpy.savez``): arrays ``depths`` (H, W)
  (uint16 raw depth or float), optional ``colors``, ``mask``, ``lims``, and scalars ``fx``, ``fy``, ``cx``,
  ``cy``, ``scale``, optional ``object_id``, ``max_grasps``. Answers an ``.npz`` with ``grasps``: the (N, 17)
  float32 graspnetAPI array.

Every limit is in :class:`ServiceLimits` (the README's "Service limits" lists them). Bad requests get 4xx
answers whose ``detail`` names what is wrong: 400 (both ``Content-Length`` and ``Transfer-Encoding``, or values
the detector rejects), 408 (body not received within ``body_timeout``), 413 (body, image or decoded arrays over
their limit), 415 (wrong content type), 422 (malformed JSON or archive, missing, unknown, mistyped or
out-of-range fields). 503 means the server is at ``max_connections``: another server (or a later try) may answer.
"""

from __future__ import annotations

import asyncio
import dataclasses
import functools
import io
import itertools
import json
import math
import os
import zipfile
from dataclasses import dataclass

import h11
import numpy as np
from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse, Response
from starlette.concurrency import run_in_threadpool
from uvicorn.protocols.http.h11_impl import H11Protocol

from .. import __version__
from ..errors import FerrobotError, InternalError
from ._detect import OPTIONS, detect_from_rgbd

__all__ = ["create_app", "ServiceLimits", "OPTION_RANGES", "FIELD_RANGES", "DEFAULT_MAX_BODY_BYTES"]

MiB = 1024 * 1024

#: Default request size limit of ``/process_npz`` (``--max-body-mb``).
DEFAULT_MAX_BODY_BYTES = 64 * MiB
_ENV_MAX_BODY = "FERROBOT_GRASP_MAX_BODY"
_ENV_LIMITS = "FERROBOT_GRASP_LIMITS"


@dataclass(frozen=True)
class ServiceLimits:
    """Every bound the service enforces (``ferrobot serve-grasp --help`` sets them).

    * ``max_body_bytes``: bytes of a ``/process_npz`` body, counted as they are read (a chunked body is cut off
      at the limit: 413).
    * ``max_json_bytes``: bytes of a ``/process`` JSON body (a 30 MiB JSON frame peaks at ~1 GB of server memory,
      parsing and detection together: BENCHMARKS.md).
    * ``max_image_side``: rows and columns of ``depths`` (and so of ``colors`` and ``mask``): 413 beyond.
    * ``max_decoded_bytes``: total size of the arrays an ``.npz`` decodes to, read from the archive's headers
      before anything is decompressed (413 beyond; the default is 4x the body limit).
    * ``body_timeout``: seconds to receive a whole request body (408 after); ``header_timeout``: seconds to
      receive a request's headers (the connection is closed after); ``keep_alive``: idle seconds between requests.
    * ``max_connections``: open connections (uvicorn's ``limit_concurrency``): a request beyond gets 503.
    * ``max_inflight``: requests decoded and detected at once; others wait their turn (bounds memory).
    * ``max_header_bytes``: bytes of a request line plus headers (h11's limit: 400 beyond).
    """

    max_body_bytes: int = DEFAULT_MAX_BODY_BYTES
    max_json_bytes: int = 32 * MiB
    max_image_side: int = 4096
    max_decoded_bytes: int = 4 * DEFAULT_MAX_BODY_BYTES
    body_timeout: float = 30.0
    header_timeout: float = 10.0
    keep_alive: float = 5.0
    max_connections: int = 64
    max_inflight: int = 2
    max_header_bytes: int = 16 * 1024

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"ServiceLimits.{f.name} must be a positive finite number, got {v!r}")
            if f.type == "int" and int(v) != v:
                raise ValueError(f"ServiceLimits.{f.name} must be an integer, got {v!r}")

    def to_env(self) -> str:
        return json.dumps(dataclasses.asdict(self))

    @classmethod
    def from_env(cls) -> ServiceLimits:
        """Limits from ``FERROBOT_GRASP_LIMITS`` (JSON, as ``serve-grasp`` sets it for its workers), with
        ``FERROBOT_GRASP_MAX_BODY`` (bytes) overriding the body limit; the defaults otherwise."""
        kw = json.loads(os.environ[_ENV_LIMITS]) if _ENV_LIMITS in os.environ else {}
        if _ENV_MAX_BODY in os.environ:
            kw["max_body_bytes"] = int(os.environ[_ENV_MAX_BODY])
            kw.setdefault("max_decoded_bytes", 4 * kw["max_body_bytes"])
        return cls(**kw)


# --------------------------------------------------------------------------------------------------------------
# One table of ranges: every scalar field and every detection option, with its type and documented range.
# The same table validates requests and writes the OpenAPI schema.


@dataclass(frozen=True)
class Range:
    """A field's type and range: ``kind`` is ``float``, ``int``, ``bool`` or ``list`` (of floats, ``length``
    items, or 1..``length`` when ``variable``); bounds ``lo``/``hi`` apply to every number, exclusive when
    ``lo_open``/``hi_open``."""

    kind: str
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    length: int = 0
    variable: bool = False
    doc: str = ""

    def describe(self) -> str:
        if self.kind == "bool":
            return "a boolean"
        lo = "(" if self.lo_open else "["
        hi = ")" if self.hi_open else "]"
        interval = f"{lo}{_fmt(self.lo)}, {_fmt(self.hi)}{hi}"
        if self.kind == "list":
            n = f"1 to {self.length}" if self.variable else f"{self.length}"
            return f"a list of {n} numbers in {interval}"
        return f"{'an integer' if self.kind == 'int' else 'a number'} in {interval}"

    def check(self, name: str, value):
        """The value converted (float, int, bool or list of floats), or a 422 naming ``name``."""
        if self.kind == "bool":
            if isinstance(value, np.ndarray) and value.shape == () and value.dtype == bool:
                value = bool(value)
            if not isinstance(value, (bool, np.bool_)):
                raise _BadRequest(422, f"field '{name}': expected a boolean, got {_type(value)}")
            return bool(value)
        if self.kind == "list":
            if isinstance(value, np.ndarray):
                value = value.tolist()
            if not isinstance(value, (list, tuple)):
                raise _BadRequest(422, f"field '{name}': expected {self.describe()}, got {_type(value)}")
            n = len(value)
            if (self.variable and not 1 <= n <= self.length) or (not self.variable and n != self.length):
                raise _BadRequest(422, f"field '{name}': expected {self.describe()}, got {n} items")
            return [self._number(f"{name}[{i}]", v, "float") for i, v in enumerate(value)]
        return self._number(name, value, self.kind)

    def _number(self, name: str, value, kind: str):
        if isinstance(value, np.ndarray):
            if value.size != 1:
                raise _BadRequest(422, f"field '{name}': expected a number, got an array of shape {value.shape}")
            value = value.item()
        elif isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _BadRequest(422, f"field '{name}': expected {self.describe()}, got {_type(value)}")
        if kind == "int":
            if isinstance(value, float):
                if not (math.isfinite(value) and value.is_integer()):
                    raise _BadRequest(422, f"field '{name}': expected {self.describe()}, got {value!r}")
                value = int(value)
            x = value
        else:
            try:
                x = float(value)
            except OverflowError:
                raise _BadRequest(422, f"field '{name}': {_short(value)} is out of range: {self.describe()}") from None
            if not math.isfinite(x):
                raise _BadRequest(422, f"field '{name}': expected a finite number, got {x}")
        below = x <= self.lo if self.lo_open else x < self.lo
        above = x >= self.hi if self.hi_open else x > self.hi
        if below or above:
            raise _BadRequest(422, f"field '{name}': {_short(value)} is out of range: expected {self.describe()}")
        return x

    def schema(self) -> dict:
        if self.kind == "bool":
            return {"type": "boolean", "description": self.doc}
        num: dict = {"type": "integer" if self.kind == "int" else "number"}
        for bound, open_, key in ((self.lo, self.lo_open, "minimum"), (self.hi, self.hi_open, "maximum")):
            if math.isfinite(bound):
                num[("exclusiveM" + key[1:]) if open_ else key] = int(bound) if self.kind == "int" else bound
        if self.kind != "list":
            return {**num, "description": self.doc}
        return {
            "type": "array",
            "items": num,
            "minItems": 1 if self.variable else self.length,
            "maxItems": self.length,
            "description": self.doc,
        }


def _fmt(x: float) -> str:
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x == int(x) and abs(x) < 1e16:
        return str(int(x))
    return f"{x:g}"


def _type(v) -> str:
    return "null" if v is None else type(v).__name__


def _short(v) -> str:
    s = repr(v)
    return s if len(s) <= 40 else s[:20] + "..." + s[-8:]


_PI = math.pi
_INT32 = (-(2**31), 2**31 - 1)

#: Range of each scalar request field (``/process`` and ``/process_npz``).
FIELD_RANGES: dict[str, Range] = {
    "fx": Range("float", 0.0, 1e6, lo_open=True, doc="focal length in pixels (columns)"),
    "fy": Range("float", 0.0, 1e6, lo_open=True, doc="focal length in pixels (rows)"),
    "cx": Range("float", -1e6, 1e6, doc="principal point, column (pixels)"),
    "cy": Range("float", -1e6, 1e6, doc="principal point, row (pixels)"),
    "scale": Range("float", 0.0, 1e6, lo_open=True, doc="raw depth units per metre (1000 for millimetres)"),
    "object_id": Range("int", *_INT32, doc="only grasps on this mask id"),
    "max_grasps": Range("int", 0, 10_000, doc="keep at most this many grasps (0: all)"),
    "lims": Range("list", -1e6, 1e6, length=6, doc="workspace [xmin, xmax, ymin, ymax, zmin, zmax], metres"),
    "workspace": Range("list", -1e6, 1e6, length=6, doc="alias of lims"),
}

#: Range of each detection option the service accepts (``options`` of ``/process``): the detector's own checks
#: (``DetectOptions::validate``) plus upper bounds on the work. With every work bound at its worst at once
#: (voxel 2 mm, normal radius 3 cm, 512 seeds x 16 rotations x 5 tilts x 6 depths) a 640 x 480 frame takes
#: ~14 s on 2 cores, ~70x the defaults (BENCHMARKS.md).
OPTION_RANGES: dict[str, Range] = {
    "voxel_size": Range("float", 0.002, 0.05, doc="voxel size of the downsampling, metres"),
    "normal_radius": Range("float", 0.002, 0.03, doc="neighbourhood radius of the normals, metres"),
    "num_seeds": Range("int", 1, 512, doc="seed points sampled"),
    "seed_spacing": Range("float", 0.0, 0.1, doc="minimum seed spacing while possible, metres"),
    "num_rotations": Range("int", 1, 16, doc="closing-axis rotations over a half turn"),
    "approach_tilts": Range(
        "list", -_PI / 2, _PI / 2, lo_open=True, hi_open=True, length=5, variable=True, doc="radians"
    ),
    "depths": Range("list", 0.0, 0.3, hi_open=True, length=6, variable=True, doc="fingertip depths, metres"),
    "friction": Range("float", 0.0, 10.0, lo_open=True, doc="friction coefficient"),
    "viewpoint": Range("list", -1e3, 1e3, length=3, doc="camera position, metres"),
    "approach_direction": Range("list", -1e3, 1e3, length=3, doc="preferred approach (non-zero)"),
    "nms_translation": Range("float", 0.0, 1.0, lo_open=True, doc="NMS distance, metres"),
    "nms_rotation": Range("float", 0.0, _PI, lo_open=True, doc="NMS angle, radians"),
    "max_grasps": FIELD_RANGES["max_grasps"],
    "seed": Range("int", 0, 2**63 - 1, doc="seed of the random sampling"),
    "support_plane": Range("bool", doc="find the table plane by RANSAC"),
    "plane_threshold": Range("float", 0.0, 0.1, lo_open=True, doc="plane inlier distance, metres"),
    "torque_scale": Range("float", 0.0, 1.0, doc="lever-arm scale of the score, metres (0: off)"),
    "body_collision": Range("bool", doc="check the hand body against the whole cloud"),
    "single_object": Range("bool", doc="reject grasps closing on another labelled object"),
    "occlusion": Range("bool", doc="reject hands in space hidden behind another object (RGB-D with mask)"),
    "wall_approaches": Range("bool", doc="also search approaches that keep the housing clear of walls"),
    "max_width": Range("float", 0.0, 0.5, lo_open=True, doc="gripper opening, metres"),
    "finger_depth": Range("float", 0.0, 0.3, lo_open=True, doc="finger length, metres"),
    "finger_width": Range("float", 0.0, 0.1, lo_open=True, doc="finger thickness, metres"),
    "height": Range("float", 0.0, 0.2, lo_open=True, doc="finger height, metres"),
    "approach_distance": Range("float", 0.0, 0.3, doc="approach corridor, metres"),
    "clearance": Range("float", 0.0, 0.05, doc="clearance, metres"),
    "palm_width": Range("float", 0.0, 1.0, lo_open=True, doc="hand housing, metres"),
    "palm_height": Range("float", 0.0, 1.0, lo_open=True, doc="hand housing, metres"),
    "palm_depth": Range("float", 0.0, 1.0, lo_open=True, doc="hand housing, metres"),
}
assert set(OPTION_RANGES) == set(OPTIONS), "OPTION_RANGES must cover exactly ferrobot.grasp.OPTIONS"

_REQUIRED = ("depths", "fx", "fy", "cx", "cy", "scale")
_ARRAYS = ("depths", "colors", "mask")
_KNOWN = set(_ARRAYS) | set(FIELD_RANGES) | {"options"}


class _BadRequest(Exception):
    def __init__(self, status: int, detail: str):
        super().__init__(detail)
        self.status = status
        self.detail = detail


# --------------------------------------------------------------------------------------------------------------
# Transport: headers, body size on the bytes read, body deadline.


async def _reply(send, status: int, detail: str, close: bool = True) -> None:
    body = json.dumps({"detail": detail}).encode()
    headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    if close:  # the rest of the body is not read: the connection cannot be reused
        headers.append((b"connection", b"close"))
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})


class _Guard:
    """ASGI middleware in front of the app: rejects a request with both ``Content-Length`` and
    ``Transfer-Encoding`` (400, RFC 9112 6.3), a declared length over the limit (413), then reads the body
    itself, counting the bytes actually received (413 at the limit, chunked or not) within ``body_timeout``
    seconds (408), and hands the app the complete body."""

    def __init__(self, app, limits: ServiceLimits):
        self.app = app
        self.limits = limits

    def _limit(self, path: str) -> int:
        """Body limit of a path: no other endpoint takes a body."""
        return {"/process": self.limits.max_json_bytes, "/process_npz": self.limits.max_body_bytes}.get(path, 0)

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        lengths = [v for k, v in scope["headers"] if k.lower() == b"content-length"]
        chunked = any(k.lower() == b"transfer-encoding" for k, _ in scope["headers"])
        if not chunked and (not lengths or lengths == [b"0"]):
            return await self.app(scope, receive, send)  # no body
        limit = self._limit(scope["path"])
        if lengths and chunked:
            return await _reply(send, 400, "a request may not carry both Content-Length and Transfer-Encoding")
        if lengths:
            try:
                n = int(lengths[0])
            except ValueError:
                n = -1
            if n < 0 or len(set(lengths)) > 1:
                return await _reply(send, 400, f"invalid Content-Length {lengths[0].decode(errors='replace')!r}")
            if n > limit:
                return await _reply(send, 413, f"request body of {n} bytes exceeds the limit of {limit} bytes")
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.limits.body_timeout
        parts: list[bytes] = []
        total = 0
        while True:
            remaining = deadline - loop.time()
            try:
                if remaining <= 0:
                    raise asyncio.TimeoutError
                message = await asyncio.wait_for(receive(), remaining)
            except asyncio.TimeoutError:
                return await _reply(
                    send, 408, f"request body not received within {self.limits.body_timeout:g} s ({total} bytes read)"
                )
            if message["type"] == "http.disconnect":
                return None  # the client went away: nobody to answer
            chunk = message.get("body", b"")
            total += len(chunk)
            if total > limit:
                return await _reply(send, 413, f"request body exceeds the limit of {limit} bytes")
            if chunk:
                parts.append(chunk)
            if not message.get("more_body", False):
                break
        body = b"".join(parts)
        del parts
        delivered = False

        async def replay():
            nonlocal delivered
            if not delivered:
                delivered = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        return await self.app(scope, replay, send)


# --------------------------------------------------------------------------------------------------------------
# Decoding: JSON and .npz, bounded before anything large is built.


def _reject_constant(name: str):
    raise ValueError(f"{name} is not valid JSON (RFC 8259 has no NaN or Infinity)")


def _parse_json(body: bytes) -> tuple[dict, bool]:
    """The parsed object, and whether the text has a ``true`` or ``false`` literal anywhere (when it has none, no
    array can hold a boolean and :func:`_image` skips looking for one)."""
    try:
        data = json.loads(body, parse_constant=_reject_constant)
    except RecursionError:
        raise _BadRequest(422, "body is not acceptable JSON: nested too deeply") from None
    except (ValueError, UnicodeDecodeError) as e:
        raise _BadRequest(422, f"body is not valid JSON: {e}") from None
    if not isinstance(data, dict):
        raise _BadRequest(422, f"body must be a JSON object, got {_type(data)}")
    return data, (b"true" in body or b"false" in body)


def _nested_shape(value, name: str, max_side: int, ndim: tuple[int, ...]) -> None:
    """Checks the outer two levels of nested lists (image rows and columns) before numpy converts them."""
    if not isinstance(value, list):
        raise _BadRequest(422, f"field '{name}': expected nested lists (H x W), got {_type(value)}")
    if len(value) > max_side:
        raise _BadRequest(413, f"field '{name}': {len(value)} rows exceed the limit of {max_side}")
    widths = {len(r) if isinstance(r, list) else -1 for r in value}
    if -1 in widths:
        raise _BadRequest(422, f"field '{name}': expected {' or '.join(f'{d}-D' for d in ndim)} nested lists")
    if widths and max(widths) > max_side:
        raise _BadRequest(413, f"field '{name}': {max(widths)} columns exceed the limit of {max_side}")
    if len(widths) > 1:
        raise _BadRequest(422, f"field '{name}': expected a rectangular array, rows have {sorted(widths)[:4]} items")


def _image(
    value, name: str, ndim: tuple[int, ...], kinds: str, limits: ServiceLimits, bools: bool = True
) -> np.ndarray:
    if not isinstance(value, np.ndarray):
        _nested_shape(value, name, limits.max_image_side, ndim)
        source = value
        try:
            value = np.array(value)
        except (ValueError, TypeError, OverflowError):
            raise _BadRequest(422, f"field '{name}': expected a rectangular array of numbers") from None
        a = value
        if bools and "b" not in kinds and a.ndim >= 2 and a.dtype.kind in "iuf":
            # numpy turns [true, 1.5] into [1.0, 1.5]: JSON booleans are not numbers
            flat = itertools.chain.from_iterable(source)
            if a.ndim == 3:
                flat = itertools.chain.from_iterable(flat)
            if any(map(_IS_BOOL, flat)):
                raise _BadRequest(422, f"field '{name}': expected numbers, got a boolean")
    a = value
    if a.ndim not in ndim:
        raise _BadRequest(422, f"field '{name}': expected {' or '.join(f'{d}-D' for d in ndim)}, got shape {a.shape}")
    if a.dtype.kind not in kinds:
        what = "numbers" if "b" not in kinds else "integers or booleans"
        raise _BadRequest(422, f"field '{name}': expected {what}, got dtype {a.dtype}")
    if max(a.shape[:2]) > limits.max_image_side:
        raise _BadRequest(413, f"field '{name}': shape {a.shape} exceeds the limit of {limits.max_image_side} pixels")
    if a.ndim == 3 and a.shape[2] != 3:
        raise _BadRequest(422, f"field '{name}': expected H x W x 3, got shape {a.shape}")
    return a


_IS_BOOL = bool.__instancecheck__
_NPZ_MAX_MEMBERS = 16


def _read_npz(body: bytes, limits: ServiceLimits) -> dict:
    """Reads an ``.npz`` after checking every member's declared size and array header (shape, dtype), so that
    nothing beyond ``max_decoded_bytes`` is ever decompressed (zipfile never inflates past a member's declared
    size)."""
    try:
        zf = zipfile.ZipFile(io.BytesIO(body))
        infos = zf.infolist()
    except (zipfile.BadZipFile, zipfile.LargeZipFile, ValueError, OSError, EOFError) as e:
        raise _BadRequest(422, f"body is not a readable .npz archive: {e}") from None
    if len(infos) > _NPZ_MAX_MEMBERS:
        raise _BadRequest(422, f"the .npz archive has {len(infos)} members; at most {_NPZ_MAX_MEMBERS} are read")
    declared = sum(i.file_size for i in infos)
    if declared > limits.max_decoded_bytes:
        raise _BadRequest(
            413, f"the .npz archive expands to {declared} bytes, over the limit of {limits.max_decoded_bytes} bytes"
        )
    names = [i.filename[:-4] if i.filename.endswith(".npy") else i.filename for i in infos]
    if len(set(names)) != len(names):
        raise _BadRequest(422, "the .npz archive names an array twice")
    unknown = sorted(set(names) - _KNOWN - {"options"})
    if unknown or "options" in names:
        raise _BadRequest(422, f"unknown field(s) {unknown or ['options']} in the .npz archive")
    data = {}
    try:
        for info, name in zip(infos, names, strict=True):
            with zf.open(info) as f:
                version = np.lib.format.read_magic(f)
                if version == (1, 0):
                    shape, _, dtype = np.lib.format.read_array_header_1_0(f)
                elif version == (2, 0):
                    shape, _, dtype = np.lib.format.read_array_header_2_0(f)
                else:
                    raise _BadRequest(422, f"field '{name}': .npy format version {version} is not supported")
                if dtype.hasobject or dtype.kind not in "biuf":
                    raise _BadRequest(422, f"field '{name}': expected numbers, got dtype {dtype}")
                if name in _ARRAYS and len(shape) >= 2 and max(shape[:2]) > limits.max_image_side:
                    raise _BadRequest(
                        413, f"field '{name}': shape {shape} exceeds the limit of {limits.max_image_side} pixels"
                    )
                nbytes = int(np.prod(shape, dtype=np.float64)) * dtype.itemsize
                if nbytes > info.file_size:
                    raise _BadRequest(422, f"field '{name}': the array header declares more data than the member")
            with zf.open(info) as f:
                data[name] = np.lib.format.read_array(f, allow_pickle=False)
    except _BadRequest:
        raise
    except Exception as e:  # noqa: BLE001 - any unreadable archive is the client's error
        raise _BadRequest(422, f"body is not a readable .npz archive: {type(e).__name__}: {e}") from None
    return data


def _run(data: dict, limits: ServiceLimits, bools: bool = True):
    unknown = sorted(set(data) - _KNOWN)
    if unknown:
        raise _BadRequest(422, f"unknown field(s) {unknown}; known: {sorted(_KNOWN)}")
    missing = [n for n in _REQUIRED if data.get(n) is None]
    if missing:
        raise _BadRequest(422, f"missing field '{missing[0]}'" + (f" (and {missing[1:]})" if missing[1:] else ""))
    depth = _image(data["depths"], "depths", (2,), "uif", limits, bools)
    if depth.size == 0:
        raise _BadRequest(422, "field 'depths': empty image")
    k = {n: FIELD_RANGES[n].check(n, data[n]) for n in ("fx", "fy", "cx", "cy", "scale")}
    colors = data.get("colors")
    if colors is not None:
        colors = _image(colors, "colors", (2, 3), "uif", limits, bools)
    mask = data.get("mask")
    if mask is not None:
        mask = _image(mask, "mask", (2,), "uifb", limits)
        if mask.dtype.kind == "f":
            if not np.all(np.isfinite(mask)) or not np.all(mask == np.round(mask)):
                raise _BadRequest(422, "field 'mask': expected integer ids or booleans")
            mask = mask.astype(np.int64)
    if "lims" in data and "workspace" in data:
        raise _BadRequest(422, "fields 'lims' and 'workspace' are aliases: give one")
    lims_name = "lims" if "lims" in data else "workspace"
    lims = data.get(lims_name)
    if lims is not None:
        lims = FIELD_RANGES[lims_name].check(lims_name, lims)
    object_id = data.get("object_id")
    if object_id is not None:
        object_id = FIELD_RANGES["object_id"].check("object_id", object_id)
    raw_options = data.get("options")
    if raw_options is None:
        raw_options = {}
    if not isinstance(raw_options, dict):
        raise _BadRequest(422, f"field 'options': expected an object, got {_type(raw_options)}")
    if "rng_seed" in raw_options:  # the old name of "seed" (deprecated; accepted for one release)
        if "seed" in raw_options:
            raise _BadRequest(422, "fields 'options.seed' and 'options.rng_seed' (deprecated) are aliases: give one")
        raw_options = {("seed" if k == "rng_seed" else k): v for k, v in raw_options.items()}
    unknown = sorted(set(raw_options) - set(OPTION_RANGES))
    if unknown:
        raise _BadRequest(422, f"field 'options': unknown option(s) {unknown}")
    options = {n: OPTION_RANGES[n].check(f"options.{n}", v) for n, v in raw_options.items()}
    if "max_grasps" in data and "max_grasps" in options:
        raise _BadRequest(422, "fields 'max_grasps' and 'options.max_grasps' are aliases: give one")
    if data.get("max_grasps") is not None:
        options["max_grasps"] = FIELD_RANGES["max_grasps"].check("max_grasps", data["max_grasps"])
    try:
        return detect_from_rgbd(
            depth, *k.values(), colors=colors, mask=mask, object_id=object_id, workspace=lims, **options
        )
    except InternalError:
        raise  # a bug, not the client's fault: 500
    except FerrobotError as e:
        raise _BadRequest(400, f"{type(e).__name__}: {e}") from None
    except (ValueError, TypeError) as e:
        raise _BadRequest(400, str(e)) from None


# --------------------------------------------------------------------------------------------------------------
# OpenAPI request schemas, written from the tables above.


def _process_schema(limits: ServiceLimits) -> dict:
    side = limits.max_image_side

    def image(item: dict, doc: str) -> dict:
        row = {"type": "array", "minItems": 1, "maxItems": side, "items": item}
        return {"type": "array", "minItems": 1, "maxItems": side, "items": row, "description": doc}

    props = {
        "depths": image({"type": "number", "minimum": 0}, "H x W raw depth (0: no reading), H, W <= max_image_side"),
        "colors": image(
            {"type": ["array", "number"], "items": {"type": "number"}, "minItems": 3, "maxItems": 3},
            "H x W x 3 colours, or H x W grey levels (checked, unused)",
        ),
        "mask": image(
            {"type": ["integer", "boolean"], "minimum": _INT32[0], "maximum": _INT32[1]},
            "H x W object ids (0: none) or booleans",
        ),
        "options": {
            "type": "object",
            "additionalProperties": False,
            "properties": {n: r.schema() for n, r in OPTION_RANGES.items()},
            "description": "detection options (ferrobot.grasp.OPTIONS)",
        },
    }
    props.update({n: r.schema() for n, r in FIELD_RANGES.items()})
    for name, prop in props.items():
        if name not in _REQUIRED:  # an optional field given as null is absent
            prop["type"] = [prop["type"], "null"]
    return {
        "type": "object",
        "required": list(_REQUIRED),
        "additionalProperties": False,
        "allOf": [  # aliases: one of each pair
            {"not": {"required": ["lims", "workspace"]}},
            {"not": {"required": ["max_grasps", "options"], "properties": {"options": {"required": ["max_grasps"]}}}},
        ],
        "properties": props,
        "description": f"AnyGrasp's request; at most max_json_bytes = {limits.max_json_bytes} bytes",
    }


_ERROR_SCHEMA = {
    "type": "object",
    "required": ["detail"],
    "properties": {"detail": {"type": "string", "description": "what is wrong, naming the field"}},
}
_GRASP_SCHEMA = {
    "type": "object",
    "required": ["translation", "rotation_matrix", "depth", "width", "score", "height", "object_id"],
    "properties": {
        "translation": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3},
        "rotation_matrix": {
            "type": "array",
            "items": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3},
            "minItems": 3,
            "maxItems": 3,
        },
        "depth": {"type": "number"},
        "width": {"type": "number"},
        "score": {"type": "number"},
        "height": {"type": "number"},
        "object_id": {"type": "integer"},
    },
}


def _errors(*codes: int) -> dict:
    text = {
        400: "invalid values (e.g. negative depth) or both Content-Length and Transfer-Encoding",
        408: "body not received within body_timeout",
        413: "body, image or decoded arrays over their limit",
        415: "wrong content type",
        422: "malformed body; missing, unknown, mistyped or out-of-range field",
    }
    return {str(c): {"description": text[c], "content": {"application/json": {"schema": _ERROR_SCHEMA}}} for c in codes}


# --------------------------------------------------------------------------------------------------------------


def create_app(max_body_bytes: int | None = None, limits: ServiceLimits | None = None):
    """The ASGI app (FastAPI behind :class:`_Guard`). ``limits`` defaults to :meth:`ServiceLimits.from_env`;
    ``max_body_bytes`` overrides its body limit (and the decoded limit, to 4x)."""
    if limits is None:
        limits = ServiceLimits.from_env()
    if max_body_bytes is not None:
        limits = dataclasses.replace(limits, max_body_bytes=max_body_bytes, max_decoded_bytes=4 * max_body_bytes)
    app = FastAPI(title="ferrobot grasp service", version=__version__)
    app.state.limits = limits
    inflight = asyncio.Semaphore(limits.max_inflight)

    @app.exception_handler(_BadRequest)
    async def _bad_request(request, exc: _BadRequest):
        return JSONResponse({"detail": exc.detail}, status_code=exc.status)

    @app.get("/health")
    async def health():
        return {"status": "ok", "version": __version__, "pid": os.getpid()}

    def process_json(body: bytes):
        data, bools = _parse_json(body)
        return {"grasp_groups": _run(data, limits, bools).to_dicts()}

    def process_npz_body(body: bytes) -> bytes:
        gg = _run(_read_npz(body, limits), limits)
        out = io.BytesIO()
        np.savez(out, grasps=gg.to_array())
        return out.getvalue()

    @app.post(
        "/process",
        openapi_extra={
            "requestBody": {"required": True, "content": {"application/json": {"schema": _process_schema(limits)}}}
        },
        responses={
            200: {
                "description": "grasps, best first, camera (OpenCV) frame",
                "content": {
                    "application/json": {
                        "schema": {
                            "type": "object",
                            "required": ["grasp_groups"],
                            "properties": {"grasp_groups": {"type": "array", "items": _GRASP_SCHEMA}},
                        }
                    }
                },
            },
            **_errors(400, 408, 413, 415, 422),
        },
    )
    async def process(request: Request):
        ctype = request.headers.get("content-type", "")
        if "json" not in ctype:
            raise _BadRequest(415, f"expected Content-Type application/json, got {ctype!r}")
        body = await request.body()
        async with inflight:
            out = await run_in_threadpool(process_json, body)
        return JSONResponse(out)

    npz_doc = (
        "numpy.savez archive: depths (H, W) numbers; fx, fy, cx, cy, scale scalars; optional colors (H, W, 3), "
        "mask (H, W) ints or bools, lims (6,), object_id, max_grasps. At most max_body_bytes = "
        f"{limits.max_body_bytes} bytes, decoding to at most max_decoded_bytes = {limits.max_decoded_bytes} bytes."
    )

    @app.post(
        "/process_npz",
        openapi_extra={
            "requestBody": {
                "required": True,
                "description": npz_doc,
                "content": {"application/octet-stream": {"schema": {"type": "string", "format": "binary"}}},
            }
        },
        responses={
            200: {
                "description": "numpy .npz with 'grasps': (N, 17) float32, graspnetAPI layout",
                "content": {"application/octet-stream": {"schema": {"type": "string", "format": "binary"}}},
            },
            **_errors(400, 408, 413, 422),
        },
    )
    async def process_npz(request: Request):
        body = await request.body()
        async with inflight:
            out = await run_in_threadpool(process_npz_body, body)
        return Response(content=out, media_type="application/octet-stream")

    return _Guard(app, limits)


# --------------------------------------------------------------------------------------------------------------
# uvicorn protocol with a request-header deadline.


@functools.lru_cache(maxsize=4)
def _header_timeout(env: str | None) -> float:
    return ServiceLimits.from_env().header_timeout


class HeaderTimeoutH11Protocol(H11Protocol):
    """uvicorn's h11 protocol plus a deadline on receiving a request's line and headers: a connection that has
    not sent complete headers ``header_timeout`` seconds after it opened (or after its previous response) is
    closed. (uvicorn itself only times out idle keep-alive connections.)"""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._header_timeout = _header_timeout(os.environ.get(_ENV_LIMITS))
        self._header_timer = None

    def _arm(self):
        self._disarm()
        self._header_timer = self.loop.call_later(self._header_timeout, self._header_deadline)

    def _disarm(self):
        if self._header_timer is not None:
            self._header_timer.cancel()
            self._header_timer = None

    def _header_deadline(self):
        self._header_timer = None
        if self.conn.their_state is h11.IDLE and not self.transport.is_closing():
            self.transport.close()

    def connection_made(self, transport):
        super().connection_made(transport)
        self._arm()

    def data_received(self, data: bytes) -> None:
        super().data_received(data)
        if self.conn.their_state is not h11.IDLE:
            self._disarm()

    def on_response_complete(self) -> None:
        super().on_response_complete()
        if not self.transport.is_closing() and self.conn.their_state is h11.IDLE:
            self._arm()

    def connection_lost(self, exc):
        self._disarm()
        super().connection_lost(exc)


def serve(host: str, port: int, workers: int, limits: ServiceLimits, log_level: str = "info") -> None:
    """Runs the service with uvicorn (h11, the header deadline, the connection limit and keep-alive of
    ``limits``). Worker processes rebuild the app and limits from the environment."""
    import uvicorn

    os.environ[_ENV_LIMITS] = limits.to_env()
    os.environ.pop(_ENV_MAX_BODY, None)
    uvicorn.run(
        "ferrobot.grasp.server:create_app",
        factory=True,
        host=host,
        port=port,
        workers=workers,
        log_level=log_level,
        http=HeaderTimeoutH11Protocol,
        limit_concurrency=limits.max_connections,
        timeout_keep_alive=limits.keep_alive,
        h11_max_incomplete_event_size=limits.max_header_bytes,
    )
