"""The grasp service under abuse (issue 15, item 6): every limit holds on the bytes actually read and the arrays
actually decoded, slow clients are cut off, every option is bounded, client mistakes get a 4xx naming the field,
and ``GraspClient`` only retries what another server could answer."""

from __future__ import annotations

import asyncio
import io
import json
import socket
import subprocess
import sys
import threading
import time
import tracemalloc
import zipfile
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import numpy as np
import pytest

import ferrobot.grasp as fg
from ferrobot.errors import RequestRejectedError, ServiceError
from ferrobot.grasp.client import GraspClient

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from ferrobot.grasp.server import OPTION_RANGES, ServiceLimits, create_app  # noqa: E402

MiB = 1024 * 1024
LIMITS = ServiceLimits(
    max_body_bytes=2 * MiB, max_json_bytes=1 * MiB, max_decoded_bytes=8 * MiB, max_image_side=256, body_timeout=0.5
)
BASE = {"depths": [[800, 800], [800, 800]], "fx": 100.0, "fy": 100.0, "cx": 0.5, "cy": 0.5, "scale": 1000.0}


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app(limits=LIMITS)) as c:
        yield c


def _post_json(client, text: str):
    return client.post("/process", content=text.encode(), headers={"content-type": "application/json"})


def _npz(**arrays) -> bytes:
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


# ---------------------------------------------------------------------------------------------------------------
# Client mistakes: 4xx naming the field, never 500.


@pytest.mark.parametrize(
    ("extra", "status", "message"),
    [
        ('"fx": 1' + "0" * 400, 422, "field 'fx'"),
        ('"fx": 1e400', 422, "field 'fx': expected a finite number"),
        ('"max_grasps": "abc"', 422, "field 'max_grasps'"),
        ('"max_grasps": 1.5', 422, "field 'max_grasps'"),
        ('"max_grasps": -1', 422, "field 'max_grasps'"),
        ('"options": [1, 2]', 422, "field 'options': expected an object"),
        ('"options": {"num_rotations": 1000000}', 422, "field 'options.num_rotations'"),
        ('"options": {"num_seeds": true}', 422, "field 'options.num_seeds'"),
        ('"options": {"support_plane": 1}', 422, "field 'options.support_plane'"),
        ('"options": {"depths": [0.01, "a"]}', 422, "field 'options.depths[1]'"),
        ('"options": {"frobnicate": 1}', 422, "unknown option(s) ['frobnicate']"),
        ('"object_id": 1099511627776', 422, "field 'object_id'"),
        ('"lims": "abc"', 422, "field 'lims'"),
        ('"colour": 1', 422, "unknown field(s) ['colour']"),
        ('"fx": NaN', 422, "not valid JSON"),
        ('"fx": Infinity', 422, "not valid JSON"),
        ('"mask": [[0, "a"], [1, 1]]', 422, "field 'mask'"),
        ('"max_grasps": 3, "options": {"max_grasps": 4}', 422, "aliases"),
        ('"lims": [0, 1, 0, 1, 0, 1], "workspace": [0, 1, 0, 1, 0, 1]', 422, "aliases"),
    ],
)
def test_json_client_mistakes_get_4xx_naming_the_field(client, extra, status, message):
    key = extra.split('"')[1]
    body = json.dumps({k: v for k, v in BASE.items() if k != key})[:-1] + ", " + extra + "}"
    r = _post_json(client, body)
    assert r.status_code == status, r.text
    assert message in r.json()["detail"]


def test_huge_numbers_inside_arrays_are_rejected(client):
    r = _post_json(client, '{"depths": [[1' + "0" * 400 + ', 1]], "fx": 1, "fy": 1, "cx": 0, "cy": 0, "scale": 1}')
    assert r.status_code == 422 and "field 'depths'" in r.json()["detail"]


def test_json_nested_100000_deep_is_4xx(client):
    r = _post_json(client, '{"depths": ' + "[" * 100_000 + "]" * 100_000 + "}")
    assert r.status_code == 422 and "nested too deeply" in r.json()["detail"]
    r = _post_json(client, "[" * 100_000 + "]" * 100_000)
    assert r.status_code == 422


@pytest.mark.parametrize(
    ("arrays", "message"),
    [
        ({"fx": np.array("abc")}, "field 'fx'"),
        ({"fx": np.array([1.0, 2.0])}, "field 'fx'"),
        ({"max_grasps": np.array(2.5)}, "field 'max_grasps'"),
        ({"object_id": np.array(2**40)}, "field 'object_id'"),
        ({"depths": np.array([["a", "b"]])}, "field 'depths'"),
        ({"depths": np.zeros((2, 2), dtype=complex)}, "field 'depths'"),
        ({"extra": np.zeros(1)}, "unknown field(s) ['extra']"),
    ],
)
def test_npz_client_mistakes_get_4xx_naming_the_field(client, arrays, message):
    fields = {k: np.asarray(v) for k, v in BASE.items()} | arrays
    r = client.post("/process_npz", content=_npz(**fields))
    assert r.status_code == 422, r.text
    assert message in r.json()["detail"]


# ---------------------------------------------------------------------------------------------------------------
# Options: one table of ranges, consistent with the detector.


def test_option_table_covers_the_detector_and_contains_its_defaults():
    assert set(OPTION_RANGES) == set(fg.OPTIONS)
    for name, default in fg.OPTIONS.items():
        r = OPTION_RANGES[name]
        if r.kind == "list":
            r.check(name, list(default))
        elif r.kind == "bool":
            assert r.check(name, default) is default
        else:
            assert r.check(name, default) == default


def _outside(r):
    """A value just outside the range (or of the wrong type for a boolean)."""
    if r.kind == "bool":
        return 1
    bad = r.hi + 1 if np.isfinite(r.hi) else r.lo - 1
    if r.kind == "int":
        bad = int(bad)
    return [bad] * (1 if r.variable else r.length) if r.kind == "list" else bad


@pytest.mark.parametrize("name", sorted(OPTION_RANGES))
def test_each_option_out_of_range_is_422_naming_it(client, name):
    r = client.post("/process", json={**BASE, "options": {name: _outside(OPTION_RANGES[name])}})
    assert r.status_code == 422, r.text
    assert f"options.{name}" in r.json()["detail"]


def test_every_range_endpoint_is_accepted_by_the_detector():
    """The service never accepts a value the library would reject (closed ends tried one at a time)."""
    rng = np.random.default_rng(0)
    pts = rng.uniform([-0.05, -0.05, 0.5], [0.05, 0.05, 0.55], size=(200, 3))
    for name, r in OPTION_RANGES.items():
        if r.kind == "bool":
            continue
        for bound, open_ in ((r.lo, r.lo_open), (r.hi, r.hi_open)):
            if open_ or not np.isfinite(bound):
                continue
            value = int(bound) if r.kind == "int" else float(bound)
            if r.kind == "list":
                value = [value] * r.length
                if name == "approach_direction" and bound == 0:
                    continue
            opts = {name: value}
            if name == "depths":
                opts["finger_depth"] = 0.3  # depths must stay below the finger length
            if name == "finger_depth":
                opts["depths"] = [min(0.04, 0.9 * value)]
            if name in ("num_seeds", "num_rotations", "voxel_size", "normal_radius"):
                opts.setdefault("approach_tilts", [0.0])
            fg.detect(pts, **opts)


# ---------------------------------------------------------------------------------------------------------------
# Sizes: JSON, image, decompressed arrays.


def test_json_has_its_own_size_limit(client):
    body = json.dumps({**BASE, "depths": [[800] * 250] * 250, "colors": [[[0.25, 0.25, 0.25]] * 250] * 250})
    assert LIMITS.max_json_bytes < len(body) < LIMITS.max_body_bytes
    r = _post_json(client, body)
    assert r.status_code == 413 and f"limit of {LIMITS.max_json_bytes} bytes" in r.json()["detail"]


def test_images_over_the_side_limit_are_413_before_conversion(client):
    r = client.post("/process", json={**BASE, "depths": [[0] * 300]})
    assert r.status_code == 413 and "300 columns exceed the limit of 256" in r.json()["detail"]
    r = client.post("/process", json={**BASE, "depths": [[0]] * 300})
    assert r.status_code == 413 and "300 rows" in r.json()["detail"]
    r = client.post("/process_npz", content=_npz(**{**BASE, "depths": np.zeros((1, 300), np.uint16)}))
    assert r.status_code == 413 and "exceeds the limit of 256 pixels" in r.json()["detail"]


def test_npz_decompression_bomb_is_refused_before_inflating(client):
    """A 12 KiB archive declaring 32 MiB of arrays: refused from the zip headers, nothing large allocated."""
    fields = {**BASE, "depths": np.zeros((64, 64)), "colors": np.zeros((2048, 2048), np.float64)}
    body = _npz(**fields)
    assert len(body) < 100_000
    tracemalloc.start()
    try:
        r = client.post("/process_npz", content=body)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert r.status_code == 413 and "expands to" in r.json()["detail"], r.text
    assert peak < 4 * MiB, peak


def _lying_npz() -> bytes:
    """An archive whose depths member declares (200, 200) float64 in its .npy header but holds 16 bytes."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (200, 200)})
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        z.writestr("depths.npy", header.getvalue() + b"\0" * 16)
        for k in ("fx", "fy", "cx", "cy", "scale"):
            buf = io.BytesIO()
            np.save(buf, np.float64(BASE[k]))
            z.writestr(k + ".npy", buf.getvalue())
    return out.getvalue()


def test_npz_member_lying_about_its_size_is_422(client):
    r = client.post("/process_npz", content=_lying_npz())
    assert r.status_code == 422 and "declares more data" in r.json()["detail"]


# ---------------------------------------------------------------------------------------------------------------
# Transport, in process: body read deadline, chunked bodies counted as read.


def _call(app, scope_headers, messages, delay_after: int):
    """Runs one request through the ASGI app: ``messages`` are delivered, then receive() stalls forever after
    ``delay_after`` of them. Returns (status, body)."""
    sent = []

    async def run():
        queue = list(messages)

        async def receive():
            if len(queue) <= len(messages) - delay_after:
                await asyncio.sleep(3600)
            return queue.pop(0)

        async def send(m):
            sent.append(m)

        scope = {
            "type": "http",
            "method": "POST",
            "path": "/process_npz",
            "headers": scope_headers,
            "query_string": b"",
            "asgi": {"version": "3.0"},
            "http_version": "1.1",
            "scheme": "http",
            "server": ("127.0.0.1", 1),
            "client": ("127.0.0.1", 2),
            "root_path": "",
        }
        await asyncio.wait_for(app(scope, receive, send), 20)

    asyncio.run(run())
    return sent[0]["status"], json.loads(sent[1]["body"]), dict(sent[0]["headers"])


def test_slow_body_gets_408_after_the_body_timeout():
    app = create_app(limits=LIMITS)
    msgs = [{"type": "http.request", "body": b"x" * 100, "more_body": True}] * 2
    status, body, headers = _call(app, [(b"content-length", b"1000")], msgs, delay_after=1)
    assert status == 408 and "not received within 0.5 s" in body["detail"]
    assert headers[b"connection"] == b"close"


def test_chunked_body_is_counted_as_read_and_cut_at_the_limit():
    app = create_app(limits=LIMITS)
    chunk = {"type": "http.request", "body": b"x" * MiB, "more_body": True}
    status, body, headers = _call(app, [(b"transfer-encoding", b"chunked")], [chunk] * 5, delay_after=5)
    assert status == 413 and f"limit of {LIMITS.max_body_bytes} bytes" in body["detail"]
    assert headers[b"connection"] == b"close"


# ---------------------------------------------------------------------------------------------------------------
# Transport, through a real uvicorn on loopback.


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def server():
    port = _free_port()
    args = ["--max-body-mb", "1", "--header-timeout", "1", "--body-timeout", "1", "--max-connections", "8"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "ferrobot.cli", "serve-grasp", "--port", str(port), "--log-level", "warning", *args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    c = GraspClient([f"http://127.0.0.1:{port}"], timeout=1.0, retries=0)
    deadline = time.monotonic() + 30
    while True:
        try:
            c.health()
            break
        except ServiceError:
            if proc.poll() is not None or time.monotonic() > deadline:
                proc.kill()
                raise RuntimeError(f"server did not start: {proc.stderr.read().decode()}") from None
            time.sleep(0.2)
    yield port
    proc.terminate()
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()


def _exchange(port: int, head: bytes, body_parts=(), wait: float = 20.0) -> bytes:
    """Sends a request head and body parts (stopping quietly if the server hangs up) and reads until the server
    closes the connection (or ``wait`` seconds pass: then b'<open>' is appended)."""
    with socket.create_connection(("127.0.0.1", port), timeout=wait) as s:
        try:
            s.sendall(head)
            for part in body_parts:
                s.sendall(part)
        except OSError:
            pass
        data = b""
        try:
            while chunk := s.recv(65536):
                data += chunk
        except TimeoutError:
            data += b"<open>"
        except ConnectionResetError:
            pass
        return data


def _chunks(n_mib: int):
    block = b"0" * MiB
    for _ in range(n_mib):
        yield b"%x\r\n" % len(block) + block + b"\r\n"
    yield b"0\r\n\r\n"


def test_content_length_with_chunked_is_400_and_not_read(server):
    head = (
        b"POST /process_npz HTTP/1.1\r\nHost: x\r\nContent-Length: 10\r\nTransfer-Encoding: chunked\r\n"
        b"Content-Type: application/octet-stream\r\n\r\n"
    )
    data = _exchange(server, head, _chunks(4))
    assert data.startswith(b"HTTP/1.1 400") and b"both Content-Length and Transfer-Encoding" in data
    assert not data.endswith(b"<open>")


def test_chunked_body_over_the_limit_is_413(server):
    head = b"POST /process_npz HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n"
    data = _exchange(server, head, _chunks(4))
    assert data.startswith(b"HTTP/1.1 413") and b"exceeds the limit of 1048576 bytes" in data


def test_slow_headers_are_disconnected(server):
    data = _exchange(server, b"POST /process HTTP/1.1\r\nHost: x\r\n")  # never finishes its headers
    assert data == b""  # closed by the server (header timeout 1 s), not left open


def test_slow_body_is_408_and_disconnected(server):
    data = _exchange(server, b"POST /process_npz HTTP/1.1\r\nHost: x\r\nContent-Length: 1000\r\n\r\nabc")
    assert data.startswith(b"HTTP/1.1 408") and not data.endswith(b"<open>")


def test_connections_over_the_limit_get_503_and_health_recovers(server):
    socks = []
    try:
        for _ in range(8):  # idle, within their header timeout
            socks.append(socket.create_connection(("127.0.0.1", server)))
        time.sleep(0.2)
        data = _exchange(server, b"GET /health HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
        assert data.startswith(b"HTTP/1.1 503")
    finally:
        for s in socks:
            s.close()
    with GraspClient([f"http://127.0.0.1:{server}"], timeout=5.0, retries=3, backoff=0.2) as c:
        assert c.health()["status"] == "ok"


# ---------------------------------------------------------------------------------------------------------------
# GraspClient: retry only what another server could answer.


class _Stub:
    """A loopback HTTP server answering every request with a fixed status and JSON body; counts requests."""

    def __init__(self, status: int, body: dict):
        stub = self
        self.hits = 0

        class Handler(BaseHTTPRequestHandler):
            def _answer(self):
                stub.hits += 1
                n = int(self.headers.get("content-length") or 0)
                self.rfile.read(n)
                data = json.dumps(body).encode()
                self.send_response(status)
                self.send_header("content-type", "application/json")
                self.send_header("content-length", str(len(data)))
                self.end_headers()
                self.wfile.write(data)

            do_GET = do_POST = _answer

            def log_message(self, *args):
                pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()

    def close(self):
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.fixture
def stubs():
    made = []

    def make(status, body):
        s = _Stub(status, body)
        made.append(s)
        return s

    yield make
    for s in made:
        s.close()


def test_client_never_replays_a_4xx_and_surfaces_the_message(stubs):
    a, b = stubs(422, {"detail": "field 'fx': expected a number"}), stubs(422, {"detail": "same"})
    with GraspClient([a.url, b.url], retries=2, backoff=0.0) as c:
        with pytest.raises(RequestRejectedError, match="field 'fx': expected a number"):
            c.health()
        assert a.hits + b.hits == 1
        assert not c._dead  # nobody marked dead for the client's mistake


def test_client_never_replays_a_500_and_reports_the_servers_error_not_an_outage(stubs):
    a, b = stubs(500, {"detail": "boom on this frame"}), stubs(500, {"detail": "boom on this frame"})
    with GraspClient([a.url, b.url], retries=2, backoff=0.0) as c:
        with pytest.raises(ServiceError, match="boom on this frame") as info:
            c.health()
        assert "no grasp server answered" not in str(info.value)
        assert not isinstance(info.value, RequestRejectedError)
        assert a.hits + b.hits == 1 and not c._dead


@pytest.mark.parametrize("status", [502, 503, 504])
def test_client_fails_over_on_overload_and_gateway_errors(stubs, status):
    busy, ok = stubs(status, {"detail": "busy"}), stubs(200, {"status": "ok", "pid": 1})
    with GraspClient([busy.url, ok.url], retries=0) as c:
        for _ in range(4):
            assert c.health()["status"] == "ok"
        assert busy.hits == 1  # tried once, then skipped during its cooldown
        assert busy.url in c._dead


def test_client_outage_lists_each_servers_reason(stubs):
    a, b = stubs(503, {"detail": "at the connection limit"}), stubs(503, {"detail": "at the connection limit"})
    with GraspClient([a.url, b.url], retries=1, backoff=0.0) as c:
        with pytest.raises(ServiceError, match="after 2 round.*HTTP 503: at the connection limit"):
            c.health()
        assert a.hits == b.hits == 2


def test_a_body_where_none_is_expected_is_refused_not_drained(client):
    r = client.request("GET", "/health", content=b"x" * 10_000)
    assert r.status_code == 413 and "limit of 0 bytes" in r.json()["detail"]
    assert client.get("/health").status_code == 200


def test_client_reports_an_unreadable_answer_as_a_service_error(stubs):
    s = stubs(200, {"not": "grasps"})
    with GraspClient([s.url], retries=0) as c:
        with pytest.raises(ServiceError, match="unreadable answer"):
            c.process(np.full((4, 4), 800, np.uint16), 100.0, 100.0, 2.0, 2.0)
        with pytest.raises(ServiceError, match="unreadable answer"):
            c.process(np.full((4, 4), 800, np.uint16), 100.0, 100.0, 2.0, 2.0, binary=False)


@pytest.mark.parametrize(
    ("flag", "value"),
    [("--max-json-mb", "0"), ("--body-timeout", "-1"), ("--header-timeout", "nan"), ("--max-image-side", "0")],
)
def test_serve_grasp_rejects_bad_limits(capsys, flag, value):
    from ferrobot.cli import main

    assert main(["serve-grasp", flag, value]) == 2
    assert f"{flag} must be > 0" in capsys.readouterr().err
