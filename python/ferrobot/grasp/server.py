"""The grasp HTTP service: a FastAPI app served by uvicorn (``ferrobot serve-grasp``).

Endpoints:

* ``GET /health``: ``{"status": "ok", "version", "pid"}``.
* ``POST /process``: the JSON body AnyGrasp client code sends: ``colors`` (H x W x 3 nested lists, optional,
  checked and unused), ``depths`` (H x W nested lists), ``fx``, ``fy``, ``cx``, ``cy``, ``scale``; optional
  ``lims`` / ``workspace`` ``[xmin, xmax, ymin, ymax, zmin, zmax]``, ``mask`` (H x W ids or booleans),
  ``object_id``, ``max_grasps`` and ``options`` (detection options, see ``ferrobot.grasp.OPTIONS``).
  Answers ``{"grasp_groups": [{"translation", "rotation_matrix", "depth", "width", "score", "height",
  "object_id"}]}``, best first, in the camera frame.
* ``POST /process_npz``: the same request as an ``.npz`` archive (``numpy.savez``): arrays ``depths`` (H, W)
  (uint16 raw depth or float), optional ``colors``, ``mask``, ``lims``, and scalars ``fx``, ``fy``, ``cx``,
  ``cy``, ``scale``, optional ``object_id``, ``max_grasps``. Answers an ``.npz`` with ``grasps``: the (N, 17)
  float32 graspnetAPI array.

Bad requests get 4xx answers whose ``detail`` names what is wrong: 400 (invalid values), 411 (no
Content-Length), 413 (body over the limit), 415 (wrong content type), 422 (malformed or missing fields).
"""

from __future__ import annotations

import io
import json
import os

import numpy as np
from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse, Response
from starlette.concurrency import run_in_threadpool

from .. import __version__
from ..errors import FerrobotError, InternalError
from ._detect import OPTIONS, detect_from_rgbd

__all__ = ["create_app", "DEFAULT_MAX_BODY_BYTES"]

#: Default request size limit: a 1280 x 720 frame as JSON with colours fits.
DEFAULT_MAX_BODY_BYTES = 64 * 1024 * 1024
_ENV_MAX_BODY = "FERROBOT_GRASP_MAX_BODY"

_SCALARS = ("fx", "fy", "cx", "cy", "scale")


class _BadRequest(Exception):
    def __init__(self, status: int, detail: str):
        super().__init__(detail)
        self.status = status
        self.detail = detail


class _BodyLimit:
    """ASGI middleware: answers 411 to a POST without Content-Length and 413 to one over ``max_bytes``."""

    def __init__(self, app, max_bytes: int):
        self.app = app
        self.max_bytes = max_bytes

    async def __call__(self, scope, receive, send):
        if scope["type"] == "http" and scope["method"] in ("POST", "PUT", "PATCH"):
            length = dict(scope["headers"]).get(b"content-length")
            status, detail = None, None
            if length is None:
                status, detail = 411, "a Content-Length header is required"
            else:
                try:
                    n = int(length)
                except ValueError:
                    n = -1
                if n < 0:
                    status, detail = 400, f"invalid Content-Length {length.decode(errors='replace')!r}"
                elif n > self.max_bytes:
                    status, detail = 413, f"request body of {n} bytes exceeds the limit of {self.max_bytes} bytes"
            if status is not None:
                body = json.dumps({"detail": detail}).encode()
                await send(
                    {
                        "type": "http.response.start",
                        "status": status,
                        "headers": [
                            (b"content-type", b"application/json"),
                            (b"content-length", str(len(body)).encode()),
                        ],
                    }
                )
                await send({"type": "http.response.body", "body": body})
                return
        await self.app(scope, receive, send)


def _field(data: dict, name: str, required: bool = True):
    if name not in data:
        if required:
            raise _BadRequest(422, f"missing field '{name}'")
        return None
    return data[name]


def _number(data: dict, name: str) -> float:
    v = _field(data, name)
    if isinstance(v, np.ndarray):
        if v.size != 1:
            raise _BadRequest(422, f"field '{name}': expected a number, got an array of shape {v.shape}")
        v = v.item()
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise _BadRequest(422, f"field '{name}': expected a number, got {type(v).__name__}")
    return float(v)


def _image(value, name: str, ndim: tuple[int, ...], dtype=np.float64) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=dtype) if not isinstance(value, np.ndarray) else value
    except (ValueError, TypeError):
        raise _BadRequest(422, f"field '{name}': expected a rectangular array of numbers") from None
    if a.ndim not in ndim:
        raise _BadRequest(422, f"field '{name}': expected {' or '.join(f'{d}-D' for d in ndim)}, got shape {a.shape}")
    if a.dtype.kind not in "uifb":
        raise _BadRequest(422, f"field '{name}': expected numbers, got dtype {a.dtype}")
    return a


def _run(data: dict):
    depth = _image(_field(data, "depths"), "depths", (2,))
    if depth.size == 0:
        raise _BadRequest(422, "field 'depths': empty image")
    k = {name: _number(data, name) for name in _SCALARS}
    colors = data.get("colors")
    if colors is not None:
        colors = _image(colors, "colors", (2, 3))
    mask = data.get("mask")
    if mask is not None:
        mask = _image(mask, "mask", (2,), dtype=None)
        if mask.dtype.kind == "f":
            if not np.all(np.isfinite(mask)) or not np.all(mask == np.round(mask)):
                raise _BadRequest(422, "field 'mask': expected integer ids or booleans")
            mask = mask.astype(np.int64)
    lims = data.get("lims", data.get("workspace"))
    object_id = data.get("object_id")
    if object_id is not None and (isinstance(object_id, bool) or not isinstance(object_id, (int, np.integer))):
        if isinstance(object_id, np.ndarray) and object_id.size == 1:
            object_id = int(object_id.item())
        else:
            raise _BadRequest(422, "field 'object_id': expected an integer")
    options = dict(data.get("options") or {})
    if not isinstance(options, dict):
        raise _BadRequest(422, "field 'options': expected an object")
    max_grasps = data.get("max_grasps")
    if max_grasps is not None:
        options["max_grasps"] = int(np.asarray(max_grasps).item())
    unknown = set(options) - set(OPTIONS)
    if unknown:
        raise _BadRequest(422, f"field 'options': unknown option(s) {sorted(unknown)}")
    try:
        return detect_from_rgbd(
            depth,
            k["fx"],
            k["fy"],
            k["cx"],
            k["cy"],
            k["scale"],
            colors=colors,
            mask=mask,
            object_id=None if object_id is None else int(object_id),
            workspace=None if lims is None else np.asarray(lims, dtype=np.float64).tolist(),
            **options,
        )
    except InternalError:
        raise  # a bug, not the client's fault: 500
    except FerrobotError as e:
        raise _BadRequest(400, f"{type(e).__name__}: {e}") from None
    except (ValueError, TypeError) as e:
        raise _BadRequest(400, str(e)) from None


def create_app(max_body_bytes: int | None = None):
    """The ASGI app (FastAPI inside a body-size limit). ``max_body_bytes`` defaults to the
    ``FERROBOT_GRASP_MAX_BODY`` environment variable, else :data:`DEFAULT_MAX_BODY_BYTES`."""
    if max_body_bytes is None:
        max_body_bytes = int(os.environ.get(_ENV_MAX_BODY, DEFAULT_MAX_BODY_BYTES))
    app = FastAPI(title="ferrobot grasp service", version=__version__)

    @app.exception_handler(_BadRequest)
    async def _bad_request(request, exc: _BadRequest):
        return JSONResponse({"detail": exc.detail}, status_code=exc.status)

    @app.get("/health")
    def health():
        return {"status": "ok", "version": __version__, "pid": os.getpid()}

    @app.post("/process")
    async def process(request: Request):
        ctype = request.headers.get("content-type", "")
        if "json" not in ctype:
            raise _BadRequest(415, f"expected Content-Type application/json, got {ctype!r}")
        body = await request.body()
        try:
            data = json.loads(body)
        except (ValueError, UnicodeDecodeError) as e:
            raise _BadRequest(422, f"body is not valid JSON: {e}") from None
        if not isinstance(data, dict):
            raise _BadRequest(422, "body must be a JSON object")
        gg = await run_in_threadpool(_run, data)
        return {"grasp_groups": gg.to_dicts()}

    @app.post("/process_npz")
    async def process_npz(request: Request):
        body = await request.body()
        try:
            with np.load(io.BytesIO(body), allow_pickle=False) as z:
                data = {k: z[k] for k in z.files}
        except Exception as e:  # noqa: BLE001 - any unreadable archive is the client's error
            raise _BadRequest(422, f"body is not a readable .npz archive: {e}") from None
        gg = await run_in_threadpool(_run, data)
        out = io.BytesIO()
        np.savez(out, grasps=gg.to_array())
        return Response(content=out.getvalue(), media_type="application/octet-stream")

    return _BodyLimit(app, max_body_bytes)
