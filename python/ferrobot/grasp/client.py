"""``GraspClient``: calls one or several grasp servers, spreading requests, with timeouts, retries and failover."""

from __future__ import annotations

import io
import itertools
import threading
import time
from collections.abc import Sequence

import numpy as np

from ..errors import RequestRejectedError, ServiceError
from ._group import GraspGroup

__all__ = ["GraspClient"]

#: Answers another server (or a later try) may not give: overloaded (503), bad gateway (502), gateway timeout (504).
_RETRYABLE = frozenset({502, 503, 504})


def _detail(r) -> str:
    """The server's reason: the JSON ``detail`` if there is one, else the body's text (cut at 500 characters)."""
    try:
        body = r.json()
        detail = body.get("detail", r.text) if isinstance(body, dict) else r.text
    except ValueError:
        detail = r.text
    detail = detail if isinstance(detail, str) else str(detail)
    return detail if len(detail) <= 500 else detail[:500] + "..."


class GraspClient:
    """A client of ``ferrobot serve-grasp`` (or any server speaking its ``/process`` protocol).

    Requests go round-robin over ``addresses`` (``"http://host:port"``). Only what another server could answer
    is sent to the next address: transport errors (connection refused or reset, timeouts) and 502, 503 (the
    server is at its connection limit) and 504 answers; such an address is skipped for ``cooldown`` seconds
    unless every address has failed. After ``retries`` full rounds (waiting ``backoff`` seconds, doubling) a
    :class:`ferrobot.errors.ServiceError` is raised listing each address's error.
    An answer about the request itself is never replayed and never marks a server dead: a 4xx raises
    :class:`ferrobot.errors.RequestRejectedError` at once, any other 5xx (the server failed on this request)
    :class:`ferrobot.errors.ServiceError`, both with the server's message. Thread-safe.
    """

    def __init__(
        self,
        addresses: str | Sequence[str],
        *,
        timeout: float = 10.0,
        retries: int = 1,
        backoff: float = 0.05,
        cooldown: float = 5.0,
        binary: bool | None = None,
    ):
        import httpx

        if isinstance(addresses, str):
            addresses = [addresses]
        self.addresses = [a.rstrip("/") for a in addresses]
        if not self.addresses:
            raise ValueError("GraspClient needs at least one server address")
        if timeout <= 0 or retries < 0 or backoff < 0 or cooldown < 0:
            raise ValueError("timeout must be > 0; retries, backoff and cooldown >= 0")
        self.retries, self.backoff, self.cooldown, self.binary = retries, backoff, cooldown, binary
        self._http = httpx.Client(timeout=timeout)
        self._rr = itertools.count()
        self._dead: dict[str, float] = {}
        self._speaks_npz: bool | None = None
        self._lock = threading.Lock()

    def close(self) -> None:
        self._http.close()

    def __enter__(self) -> GraspClient:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _order(self) -> list[str]:
        with self._lock:
            start = next(self._rr) % len(self.addresses)
            now = time.monotonic()
            ring = self.addresses[start:] + self.addresses[:start]
            alive = [a for a in ring if self._dead.get(a, 0.0) <= now]
            return alive + [a for a in ring if a not in alive]

    def _mark(self, address: str, ok: bool) -> None:
        with self._lock:
            if ok:
                self._dead.pop(address, None)
            else:
                self._dead[address] = time.monotonic() + self.cooldown

    def _request(self, method: str, path: str, **kwargs):
        import httpx

        errors: dict[str, str] = {}
        delay = self.backoff
        for attempt in range(self.retries + 1):
            for address in self._order():
                try:
                    r = self._http.request(method, address + path, **kwargs)
                except httpx.TransportError as e:  # unreachable, reset, timed out: another server may answer
                    errors[address] = f"{type(e).__name__}: {e}"
                    self._mark(address, False)
                    continue
                except httpx.HTTPError as e:  # not the network's fault (e.g. an undecodable answer)
                    raise ServiceError(f"{address}{path}: {type(e).__name__}: {e}") from None
                if r.status_code in _RETRYABLE:  # overloaded, or a proxy with no server behind it
                    errors[address] = f"HTTP {r.status_code}: {_detail(r)}"
                    self._mark(address, False)
                    continue
                self._mark(address, True)  # it answered: alive, whatever it thinks of the request
                if r.status_code >= 500:  # the server failed on this request: replaying it elsewhere won't help
                    raise ServiceError(f"{address}{path} failed on the request (HTTP {r.status_code}): {_detail(r)}")
                if r.status_code >= 400:
                    raise RequestRejectedError(
                        f"{address}{path} rejected the request (HTTP {r.status_code}): {_detail(r)}"
                    )
                return r
            if attempt < self.retries:
                time.sleep(delay)
                delay *= 2
        listing = "; ".join(f"{a}: {e}" for a, e in errors.items())
        raise ServiceError(f"no grasp server answered {path} after {self.retries + 1} round(s): {listing}")

    def health(self) -> dict:
        """``/health`` of the first server that answers."""
        return self._request("GET", "/health").json()

    def process(
        self,
        depths,
        fx: float,
        fy: float,
        cx: float,
        cy: float,
        scale: float = 1000.0,
        *,
        colors=None,
        mask=None,
        object_id: int | None = None,
        lims=None,
        max_grasps: int | None = None,
        binary: bool | None = None,
    ) -> GraspGroup:
        """Grasps for one RGB-D frame (camera frame), best first. ``binary`` (default: the client's) sends an
        ``.npz`` to ``/process_npz`` (uint16 depth stays uint16); otherwise JSON to ``/process``. When neither
        says, the client asks ``/health`` once: a ferrobot server gets ``.npz``, any other server (an AnyGrasp
        Flask server) JSON. JSON answers may leave fields out (see :meth:`GraspGroup.from_dicts`)."""
        binary = self.binary if binary is None else binary
        if binary is None:
            binary = self._server_is_ferrobot()
        depths = np.asarray(depths)
        if binary:
            arrays = {"depths": depths, "fx": fx, "fy": fy, "cx": cx, "cy": cy, "scale": scale}
            for name, v in (("colors", colors), ("mask", mask), ("lims", lims)):
                if v is not None:
                    arrays[name] = np.asarray(v)
            if object_id is not None:
                arrays["object_id"] = object_id
            if max_grasps is not None:
                arrays["max_grasps"] = max_grasps
            buf = io.BytesIO()
            np.savez(buf, **arrays)
            r = self._request(
                "POST", "/process_npz", content=buf.getvalue(), headers={"content-type": "application/octet-stream"}
            )
            try:
                with np.load(io.BytesIO(r.content), allow_pickle=False) as z:
                    return GraspGroup(z["grasps"].astype(np.float64))
            except Exception as e:  # noqa: BLE001 - whatever is wrong with the answer, it is the server's
                raise ServiceError(f"{r.url}: unreadable answer ({type(e).__name__}: {e})") from None
        body = {"depths": depths.tolist(), "fx": fx, "fy": fy, "cx": cx, "cy": cy, "scale": scale}
        if colors is not None:
            body["colors"] = np.asarray(colors).tolist()
        if mask is not None:
            body["mask"] = np.asarray(mask).tolist()
        if lims is not None:
            body["lims"] = np.asarray(lims, dtype=float).tolist()
        if object_id is not None:
            body["object_id"] = int(object_id)
        if max_grasps is not None:
            body["max_grasps"] = int(max_grasps)
        r = self._request("POST", "/process", json=body)
        return _parse_json_grasps(r)

    def _server_is_ferrobot(self) -> bool:
        """Whether the servers speak ferrobot's ``/process_npz`` (asked once, through ``/health``)."""
        if self._speaks_npz is None:
            try:
                h = self._request("GET", "/health").json()
            except (RequestRejectedError, ValueError):
                h = None
            self._speaks_npz = isinstance(h, dict) and {"status", "version", "pid"} <= set(h)
        return self._speaks_npz


def _parse_json_grasps(r) -> GraspGroup:
    """A ``/process`` answer: ``{"grasp_groups": [...]}`` (ferrobot, AnyGrasp servers), ``{"grasps": [...]}``,
    a bare list of grasp dicts, or an (N, 17) array under ``grasp_group_array`` / ``grasp_array``."""
    try:
        data = r.json()
    except ValueError as e:
        raise ServiceError(f"{r.url}: unreadable answer (not JSON: {r.text[:200]!r})") from e
    if isinstance(data, dict):
        for key in ("grasp_group_array", "grasp_array"):
            if key in data:
                try:
                    return GraspGroup(np.asarray(data[key], dtype=np.float64).reshape(-1, 17))
                except (TypeError, ValueError) as e:
                    raise ServiceError(f"{r.url}: unreadable answer ({key}: {type(e).__name__}: {e})") from None
        for key in ("grasp_groups", "grasps"):
            if key in data:
                data = data[key]
                break
        else:
            raise ServiceError(f"{r.url}: unreadable answer (no grasps; keys {sorted(data)})")
    if not isinstance(data, list):
        raise ServiceError(f"{r.url}: unreadable answer (expected a list of grasps, got {type(data).__name__})")
    try:
        return GraspGroup.from_dicts(data)
    except Exception as e:  # noqa: BLE001 - whatever is wrong with the answer, it is the server's
        raise ServiceError(f"{r.url}: unreadable answer ({type(e).__name__}: {e})") from None
