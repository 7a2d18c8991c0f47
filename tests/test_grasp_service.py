"""The grasp HTTP service: in-process (FastAPI TestClient) and as real ``ferrobot serve-grasp`` processes."""

from __future__ import annotations

import io
import socket
import subprocess
import sys
import time

import numpy as np
import pytest
from grasp_scenes import default_scene, render

import ferrobot.grasp as fg
from ferrobot.cli import main
from ferrobot.errors import RequestRejectedError, ServiceError
from ferrobot.grasp.client import GraspClient

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from ferrobot.grasp.server import create_app  # noqa: E402

W, H, F = 320, 240, 300.0
CX, CY = 159.5, 119.5


@pytest.fixture(scope="module")
def frame():
    scene, cam = default_scene()
    depth, labels = render(scene, cam, width=W, height=H, fx=F, fy=F, cx=CX, cy=CY)
    mm = np.round(depth * 1000).astype(np.uint16)
    colors = np.zeros((H, W, 3), dtype=np.uint8)
    colors[labels > 0] = [200, 30, 30]
    return mm, colors, labels


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app(max_body_bytes=8 * 1024 * 1024)) as c:
        yield c


def _body(mm, colors=None, **extra):
    body = {"depths": mm.tolist(), "fx": F, "fy": F, "cx": CX, "cy": CY, "scale": 1000.0}
    if colors is not None:
        body["colors"] = colors.tolist()
    body.update(extra)
    return body


def test_health(client):
    r = client.get("/health")
    import ferrobot

    assert r.status_code == 200
    assert (
        r.json()["status"] == "ok" and r.json()["version"] == ferrobot.__version__ and isinstance(r.json()["pid"], int)
    )


def test_json_endpoint_matches_the_library(client, frame):
    mm, colors, _ = frame
    r = client.post("/process", json=_body(mm, colors))
    assert r.status_code == 200, r.text
    items = r.json()["grasp_groups"]
    want = fg.detect_from_rgbd(mm, F, F, CX, CY, 1000.0)
    assert len(items) == len(want) > 0
    for item, g in zip(items, want, strict=True):
        assert {"translation", "rotation_matrix", "depth", "width", "score"} <= set(item)
        np.testing.assert_allclose(item["translation"], g.translation)
        np.testing.assert_allclose(item["rotation_matrix"], g.rotation_matrix)
        assert item["score"] == pytest.approx(g.score) and item["width"] == pytest.approx(g.width)
        assert item["depth"] == pytest.approx(g.depth)
    scores = [i["score"] for i in items]
    assert scores == sorted(scores, reverse=True)


def test_binary_endpoint_matches_json(client, frame):
    mm, colors, labels = frame
    buf = io.BytesIO()
    np.savez(buf, depths=mm, colors=colors, mask=labels, fx=F, fy=F, cx=CX, cy=CY, scale=1000.0, max_grasps=5)
    r = client.post("/process_npz", content=buf.getvalue(), headers={"content-type": "application/octet-stream"})
    assert r.status_code == 200, r.text
    with np.load(io.BytesIO(r.content)) as z:
        arr = z["grasps"]
    assert arr.dtype == np.float32 and arr.shape[1] == 17 and 0 < len(arr) <= 5
    want = fg.detect_from_rgbd(mm, F, F, CX, CY, 1000.0, mask=labels, max_grasps=5)
    np.testing.assert_allclose(arr, want.to_array(), rtol=1e-6, atol=1e-7)
    assert set(arr[:, 16].astype(int)) <= {1, 2}


@pytest.mark.parametrize(
    ("body", "status", "message"),
    [
        ({"fx": 1.0}, 422, "missing field 'depths'"),
        ({"depths": [[1, 2], [3]], "fx": 1, "fy": 1, "cx": 0, "cy": 0, "scale": 1}, 422, "rectangular"),
        ({"depths": [1, 2, 3], "fx": 1, "fy": 1, "cx": 0, "cy": 0, "scale": 1}, 422, "expected 2-D"),
        ({"depths": [[1, 2]], "fy": 1, "cx": 0, "cy": 0, "scale": 1}, 422, "missing field 'fx'"),
        ({"depths": [[1, 2]], "fx": "a", "fy": 1, "cx": 0, "cy": 0, "scale": 1}, 422, "'fx': expected a number"),
        ({"depths": [[1, 2]], "fx": 1, "fy": 1, "cx": 0, "cy": 0, "scale": 0}, 422, "field 'scale': 0 is out of range"),
        ({"depths": [[1, -2]], "fx": 1, "fy": 1, "cx": 0, "cy": 0, "scale": 1}, 400, "negative depth"),
        ({"depths": [[1, 2]], "fx": 1, "fy": 1, "cx": 0, "cy": 0, "scale": 1, "colors": [[1, 2, 3]]}, 400, "colors"),
        (
            {"depths": [[1, 2]], "fx": 1, "fy": 1, "cx": 0, "cy": 0, "scale": 1, "lims": [0, 1]},
            422,
            "'lims': expected a list of 6",
        ),
        (
            {"depths": [[1, 2]], "fx": 1, "fy": 1, "cx": 0, "cy": 0, "scale": 1, "lims": [1, 0, 0, 1, 0, 1]},
            400,
            "workspace",
        ),
        ({"depths": [[1, 2]], "fx": 1, "fy": 1, "cx": 0, "cy": 0, "scale": 1, "options": {"x": 1}}, 422, "unknown"),
    ],
)
def test_bad_json_requests_say_what_is_wrong(client, body, status, message):
    r = client.post("/process", json=body)
    assert r.status_code == status, r.text
    assert message in r.json()["detail"]


def test_transport_level_errors(client):
    r = client.post("/process", content=b"{not json", headers={"content-type": "application/json"})
    assert r.status_code == 422 and "not valid JSON" in r.json()["detail"]
    r = client.post("/process", content=b"x=1", headers={"content-type": "text/plain"})
    assert r.status_code == 415
    r = client.post("/process_npz", content=b"garbage", headers={"content-type": "application/octet-stream"})
    assert r.status_code == 422 and ".npz" in r.json()["detail"]
    big = b"0" * (8 * 1024 * 1024 + 1)
    r = client.post("/process_npz", content=big, headers={"content-type": "application/octet-stream"})
    assert r.status_code == 413 and "exceeds the limit" in r.json()["detail"]
    r = client.post("/process_npz", content=iter([b"ab", b"cd"]))  # chunked: read, counted, then parsed
    assert r.status_code == 422 and ".npz" in r.json()["detail"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _serve(port: int) -> subprocess.Popen:
    proc = subprocess.Popen(
        [sys.executable, "-m", "ferrobot.cli", "serve-grasp", "--port", str(port), "--log-level", "warning"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    c = GraspClient([f"http://127.0.0.1:{port}"], timeout=1.0, retries=0)
    deadline = time.monotonic() + 30
    while True:
        try:
            c.health()
            return proc
        except ServiceError:
            if proc.poll() is not None or time.monotonic() > deadline:
                proc.kill()
                raise RuntimeError(f"server did not start: {proc.stderr.read().decode()}") from None
            time.sleep(0.2)


@pytest.fixture(scope="module")
def servers():
    ports = [_free_port(), _free_port()]
    procs = [_serve(p) for p in ports]
    yield [f"http://127.0.0.1:{p}" for p in ports]
    for p in procs:
        p.terminate()
    for p in procs:
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()


def test_real_server_through_the_client_with_failover(servers, frame):
    mm, colors, labels = frame
    dead = f"http://127.0.0.1:{_free_port()}"
    with GraspClient([dead, servers[0]], timeout=20.0, retries=1, backoff=0.01) as c:
        for _ in range(3):  # round-robin starts on the dead address every other call: failover each time
            gg = c.process(mm, F, F, CX, CY, 1000.0, colors=colors, mask=labels)
            assert len(gg) > 0 and set(gg.object_ids) <= {1, 2}
        want = fg.detect_from_rgbd(mm, F, F, CX, CY, 1000.0, mask=labels)
        np.testing.assert_allclose(gg.to_array(), want.to_array(), rtol=1e-6, atol=1e-7)
        js = c.process(mm, F, F, CX, CY, 1000.0, mask=labels, binary=False)
        np.testing.assert_allclose(js.translations, want.translations, atol=1e-9)
        with pytest.raises(RequestRejectedError, match="field 'scale': 0.0 is out of range"):
            c.process(mm, F, F, CX, CY, 0.0)


def test_client_spreads_requests_and_reports_dead_servers(servers):
    with GraspClient(servers, timeout=5.0) as c:
        pids = {c.health()["pid"] for _ in range(4)}
    assert len(pids) == 2
    dead = [f"http://127.0.0.1:{_free_port()}", f"http://127.0.0.1:{_free_port()}"]
    with GraspClient(dead, timeout=1.0, retries=1, backoff=0.01) as c:
        with pytest.raises(ServiceError, match="no grasp server answered /health after 2 round"):
            c.health()


def test_serve_grasp_rejects_bad_arguments(capsys):
    assert main(["serve-grasp", "--workers", "0"]) == 2
    assert "--workers must be >= 1" in capsys.readouterr().err
