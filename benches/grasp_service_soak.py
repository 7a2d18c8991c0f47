"""Soak test of the grasp service: valid and hostile requests at once, on loopback only.

    python benches/grasp_service_soak.py [--duration 60] [--json FILE] [--rss-limit-mb 512]

Starts ``ferrobot serve-grasp`` on 127.0.0.1 (a free port; ``--max-body-mb 8 --max-json-mb 8 --body-timeout 2
--header-timeout 2 --max-connections 64``, other limits at their defaults) and, for ``--duration`` seconds, runs
concurrently:

* valid clients: 2 threads posting a rendered 320 x 240 uint16 frame (two objects) to ``/process_npz`` and
  1 thread posting it as JSON to ``/process``; each answer must be 200 with at least one grasp;
* hostile clients, 2 threads cycling through: a Content-Length over the limit, Content-Length plus chunked,
  a chunked body past the limit, an ``.npz`` decompression bomb, a 2-D 5000 x 1 JSON image, JSON nested
  100,000 deep, ``num_rotations = 10**6``, ``fx = 10**400``, garbage ``.npz``, a body that stalls (408 after
  the body timeout), headers that never finish (closed after the header timeout); each must get a 4xx or be
  disconnected, never a 5xx;
* 8 connections that each trickle a body one byte a second (cut off at the body timeout, then reopened);
* ``GET /health`` every 0.25 s (5 s timeout): every one must answer 200;
* the server's resident memory (VmRSS from /proc, the server process and its children) every 0.1 s.

``--no-hostile`` runs the valid clients and ``/health`` alone (a baseline for the latencies).
``--largest`` sends, one at a time to a server with default limits, the largest requests it accepts: a 4096 x 4096
float64 ``.npz`` frame with colours and a JSON frame just under the JSON limit, with their time and peak RSS.
``--latency`` times valid 640 x 480 requests (JSON with colours, and ``.npz``) one at a time, 10 rounds; with
``--baseline-pythonpath DIR`` a second server importing ferrobot from DIR (e.g. another checkout's ``python``)
is timed in the same rounds, interleaved.
``--worst-options`` instead times detection on a rendered 640 x 480 frame with the default options and with every
work bound of the service's option table at its worst at once (interleaved, 3 runs each, median).

Prints (and writes with ``--json``) the counts, the valid requests' p50/p95 latency, the maximum RSS and every
failure; exits 1 if a valid request was lost, a health check failed, a hostile request got a 5xx or RSS went
over ``--rss-limit-mb``.
"""

from __future__ import annotations

import argparse
import collections
import io
import json
import os
import socket
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from grasp_scenes import default_scene, render  # noqa: E402

W, H, F, CX, CY = 320, 240, 300.0, 159.5, 119.5
MiB = 1024 * 1024
LIMIT_MB = 8


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _rss_kb(pid: int) -> int:
    """VmRSS of ``pid`` and its descendants (uvicorn workers), in KiB."""
    total, todo = 0, [pid]
    while todo:
        p = todo.pop()
        try:
            with open(f"/proc/{p}/status") as f:
                total += next(int(line.split()[1]) for line in f if line.startswith("VmRSS"))
            with open(f"/proc/{p}/task/{p}/children") as f:
                todo += [int(c) for c in f.read().split()]
        except (OSError, StopIteration):
            pass
    return total


def _exchange(port: int, head: bytes, parts=(), wait: float = 30.0) -> bytes:
    """Raw HTTP/1.1: sends head and body parts (stops quietly when the server hangs up), reads to EOF."""
    with socket.create_connection(("127.0.0.1", port), timeout=wait) as s:
        try:
            s.sendall(head)
            for p in parts:
                s.sendall(p)
        except OSError:
            pass
        data = b""
        try:
            while chunk := s.recv(65536):
                data += chunk
                if b"\r\n\r\n" in data and b"connection: close" not in data.lower():
                    break  # an answer on a kept-alive connection: enough
        except TimeoutError:
            data += b"<open>"
        except OSError:
            pass
        return data


def _status(data: bytes) -> str:
    if not data:
        return "closed"
    if data.endswith(b"<open>") and not data.startswith(b"HTTP/"):
        return "open"
    try:
        return data.split(b" ", 2)[1].decode()
    except IndexError:
        return "garbled"


def _npz(**arrays) -> bytes:
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


def _chunked(n_mib: int):
    block = b"0" * MiB
    for _ in range(n_mib):
        yield b"%x\r\n" % len(block) + block + b"\r\n"
    yield b"0\r\n\r\n"


def hostile_requests(port: int):
    """(name, thunk returning the status string) for every attack."""
    k = {"fx": F, "fy": F, "cx": CX, "cy": CY, "scale": 1000.0}
    bomb = _npz(depths=np.zeros((4000, 4000), np.float64), **k)  # 128 MB declared, ~130 KB sent
    big = LIMIT_MB * MiB + 1

    def post(path, body: bytes, ctype=b"application/json", extra=b""):
        head = b"POST %s HTTP/1.1\r\nHost: x\r\nContent-Type: %s\r\nContent-Length: %d\r\n%s\r\n" % (
            path.encode(),
            ctype,
            len(body),
            extra,
        )
        return _status(_exchange(port, head, [body]))

    def js(obj_text: str):
        return post("/process", obj_text.encode())

    base = json.dumps({**k, "depths": [[800, 800], [800, 800]]})[:-1]
    return [
        (
            "oversize_content_length",
            lambda: _status(
                _exchange(port, b"POST /process_npz HTTP/1.1\r\nHost: x\r\nContent-Length: %d\r\n\r\n" % big)
            ),
        ),
        (
            "content_length_and_chunked",
            lambda: _status(
                _exchange(
                    port,
                    b"POST /process_npz HTTP/1.1\r\nHost: x\r\nContent-Length: 10\r\n"
                    b"Transfer-Encoding: chunked\r\n\r\n",
                    _chunked(LIMIT_MB + 2),
                )
            ),
        ),
        (
            "chunked_over_limit",
            lambda: _status(
                _exchange(
                    port,
                    b"POST /process_npz HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n",
                    _chunked(LIMIT_MB + 2),
                )
            ),
        ),
        ("npz_bomb", lambda: post("/process_npz", bomb, b"application/octet-stream")),
        ("json_image_too_large", lambda: js(json.dumps({**k, "depths": [[1]] * 5000}))),
        ("json_nested_100000", lambda: js('{"depths": ' + "[" * 100_000 + "]" * 100_000 + "}")),
        ("num_rotations_1e6", lambda: js(base + ', "options": {"num_rotations": 1000000}}')),
        ("fx_10_400", lambda: js(base.replace('"fx": 300.0', '"fx": 1' + "0" * 400) + "}")),
        ("max_grasps_abc", lambda: js(base + ', "max_grasps": "abc"}')),
        ("options_list", lambda: js(base + ', "options": [1, 2]}')),
        ("garbage_npz", lambda: post("/process_npz", os.urandom(4096), b"application/octet-stream")),
        (
            "stalled_body",
            lambda: _status(
                _exchange(port, b"POST /process_npz HTTP/1.1\r\nHost: x\r\nContent-Length: 100000\r\n\r\nabc")
            ),
        ),
        ("unfinished_headers", lambda: _status(_exchange(port, b"POST /process HTTP/1.1\r\nHost: x\r\n"))),
    ]


def _start_server(extra=()) -> tuple[subprocess.Popen, str]:
    import httpx

    port = _free_port()
    cmd = [sys.executable, "-m", "ferrobot.cli", "serve-grasp", "--host", "127.0.0.1", "--port", str(port)]
    server = subprocess.Popen([*cmd, "--log-level", "critical", *extra], stdout=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while True:
        try:
            httpx.get(url + "/health", timeout=1.0)
            return server, url
        except httpx.HTTPError:
            if server.poll() is not None or time.monotonic() > deadline:
                server.kill()
                raise RuntimeError("the server did not start") from None
            time.sleep(0.2)


def latency(baseline: str | None) -> int:
    import httpx

    servers = {"this tree": _start_server()}
    if baseline:
        env = dict(os.environ, PYTHONPATH=baseline)
        port = _free_port()
        cmd = [sys.executable, "-m", "ferrobot.cli", "serve-grasp", "--port", str(port), "--log-level", "critical"]
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL)
        url = f"http://127.0.0.1:{port}"
        for _ in range(300):
            try:
                httpx.get(url + "/health", timeout=1.0)
                break
            except httpx.HTTPError:
                time.sleep(0.2)
        servers[f"baseline ({baseline})"] = (proc, url)
    w, h, f = 640, 480, 600.0
    k = {"fx": f, "fy": f, "cx": w / 2 - 0.5, "cy": h / 2 - 0.5, "scale": 1000.0}
    scene, cam = default_scene()
    depth, labels = render(scene, cam, width=w, height=h, fx=f, fy=f, cx=k["cx"], cy=k["cy"])
    mm = np.round(depth * 1000).astype(np.uint16)
    colors = np.zeros((h, w, 3), np.uint8)
    colors[labels > 0] = [200, 30, 30]
    bodies = {
        "JSON": ("/process", json.dumps({"depths": mm.tolist(), "colors": colors.tolist(), **k}).encode()),
        "npz": ("/process_npz", _npz(depths=mm, colors=colors, **k)),
    }
    times: dict[tuple[str, str], list[float]] = collections.defaultdict(list)
    with httpx.Client(timeout=120.0) as c:
        for _ in range(10):
            for name, (_, url) in servers.items():
                for kind, (path, body) in bodies.items():
                    t = time.perf_counter()
                    r = c.post(url + path, content=body, headers={"content-type": "application/json"})
                    times[(name, kind)].append(time.perf_counter() - t)
                    assert r.status_code == 200, r.text
    for (name, kind), ts in times.items():
        print(f"{name:40s} {kind:5s} median {1e3 * statistics.median(ts):7.1f} ms  min {1e3 * min(ts):7.1f} ms")
    for proc, _ in servers.values():
        proc.terminate()
        proc.wait(timeout=10)
    return 0


def largest() -> int:
    import httpx

    server, url = _start_server()
    peak = [0]
    stop = threading.Event()

    def memory():
        while not stop.is_set():
            peak[0] = max(peak[0], _rss_kb(server.pid))
            stop.wait(0.05)

    threading.Thread(target=memory, daemon=True).start()
    n = 4096
    k = {"fx": 1.5 * n, "fy": 1.5 * n, "cx": n / 2, "cy": n / 2, "scale": 1000.0}
    scene, cam = default_scene()
    depth, _ = render(scene, cam, width=n, height=n, fx=k["fx"], fy=k["fy"], cx=k["cx"], cy=k["cy"])
    mm = np.round(np.nan_to_num(depth) * 1000).astype(np.uint16)
    npz = _npz(depths=mm.astype(np.float64), colors=np.zeros((n, n, 3), np.uint8), **k)
    side = 2600  # the largest square millimetre image whose JSON fits the default 32 MiB
    body = json.dumps({"depths": mm[:side, :side].tolist(), **k}).encode()
    ok = True
    for name, path, data, ctype in (
        (f"npz {n}x{n} float64 depth + uint8 colours", "/process_npz", npz, "application/octet-stream"),
        (f"JSON {side}x{side} millimetre depth", "/process", body, "application/json"),
    ):
        peak[0] = 0
        t = time.perf_counter()
        r = httpx.post(url + path, content=data, headers={"content-type": ctype}, timeout=600)
        ok &= r.status_code == 200
        print(
            f"{name}: {len(data) / MiB:.1f} MiB sent -> HTTP {r.status_code} in {time.perf_counter() - t:.1f} s, "
            f"peak server RSS {peak[0] / 1024:.0f} MB",
            flush=True,
        )
    stop.set()
    server.terminate()
    server.wait(timeout=10)
    return 0 if ok else 1


def worst_options() -> int:
    import ferrobot.grasp as fg
    from ferrobot.grasp.server import OPTION_RANGES

    r = OPTION_RANGES
    worst = {
        "voxel_size": r["voxel_size"].lo,
        "normal_radius": r["normal_radius"].hi,
        "num_seeds": int(r["num_seeds"].hi),
        "num_rotations": int(r["num_rotations"].hi),
        "approach_tilts": list(np.linspace(-1.5, 1.5, r["approach_tilts"].length)),
        "depths": list(np.linspace(0.045, 0.005, r["depths"].length)),
        "seed_spacing": r["seed_spacing"].hi,
        "nms_translation": r["nms_translation"].hi,
    }
    w, h, f = 640, 480, 600.0
    scene, cam = default_scene()
    depth, _ = render(scene, cam, width=w, height=h, fx=f, fy=f, cx=w / 2 - 0.5, cy=h / 2 - 0.5)
    mm = np.round(depth * 1000).astype(np.uint16)
    times: dict[str, list[float]] = {"default": [], "worst": []}
    for _ in range(3):
        for name, opts in (("default", {}), ("worst", worst)):
            t = time.perf_counter()
            n = len(fg.detect_from_rgbd(mm, f, f, w / 2 - 0.5, h / 2 - 0.5, 1000.0, **opts))
            times[name].append(time.perf_counter() - t)
            print(f"{name:8s} {times[name][-1]:7.2f} s  {n} grasps", flush=True)
    d, x = statistics.median(times["default"]), statistics.median(times["worst"])
    print(f"median: default {d:.2f} s, worst {x:.2f} s ({x / d:.0f}x); worst options: {worst}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=60.0, help="seconds of load (default 60)")
    ap.add_argument("--json", default=None, help="write the summary here")
    ap.add_argument("--rss-limit-mb", type=float, default=512.0, help="fail above this server RSS (default 512)")
    ap.add_argument("--no-hostile", action="store_true", help="valid clients and /health only (a baseline)")
    ap.add_argument(
        "--latency", action="store_true", help="time valid 640x480 requests alone (see --baseline-pythonpath)"
    )
    ap.add_argument(
        "--baseline-pythonpath", default=None, help="with --latency: also a server importing ferrobot from here"
    )
    ap.add_argument("--largest", action="store_true", help="time the largest accepted requests instead")
    ap.add_argument("--worst-options", action="store_true", help="time the worst-case options instead")
    args = ap.parse_args(argv)
    if args.worst_options:
        return worst_options()
    if args.largest:
        return largest()
    if args.latency:
        return latency(args.baseline_pythonpath)

    import httpx

    scene, cam = default_scene()
    depth, labels = render(scene, cam, width=W, height=H, fx=F, fy=F, cx=CX, cy=CY)
    mm = np.round(depth * 1000).astype(np.uint16)
    k = {"fx": F, "fy": F, "cx": CX, "cy": CY, "scale": 1000.0}
    npz_body = _npz(depths=mm, **k)
    json_body = json.dumps({"depths": mm.tolist(), **k}).encode()

    port = _free_port()
    cmd = [sys.executable, "-m", "ferrobot.cli", "serve-grasp", "--host", "127.0.0.1", "--port", str(port)]
    cmd += ["--max-body-mb", str(LIMIT_MB), "--max-json-mb", str(LIMIT_MB), "--body-timeout", "2"]
    cmd += ["--header-timeout", "2", "--max-connections", "64", "--log-level", "critical"]
    server = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while True:
        try:
            httpx.get(url + "/health", timeout=1.0)
            break
        except httpx.HTTPError:
            if server.poll() is not None or time.monotonic() > deadline:
                server.kill()
                print(server.stderr.read().decode(), file=sys.stderr)
                return 1
            time.sleep(0.2)

    stop = threading.Event()
    lock = threading.Lock()
    latencies: list[float] = []
    counts: collections.Counter = collections.Counter()
    hostile: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    failures: list[str] = []
    rss_start = _rss_kb(server.pid)
    rss_max = [rss_start]
    health_max = [0.0]

    def fail(msg: str):
        with lock:
            if len(failures) < 50:
                failures.append(msg)

    def valid(binary: bool):
        with httpx.Client(timeout=120.0) as c:
            while not stop.is_set():
                t = time.perf_counter()
                kind = "valid_npz" if binary else "valid_json"
                try:
                    if binary:
                        r = c.post(url + "/process_npz", content=npz_body)
                        ok = r.status_code == 200 and len(np.load(io.BytesIO(r.content))["grasps"]) > 0
                    else:
                        r = c.post(url + "/process", content=json_body, headers={"content-type": "application/json"})
                        ok = r.status_code == 200 and len(r.json()["grasp_groups"]) > 0
                    detail = f"HTTP {r.status_code}: {r.text[:200] if r.status_code != 200 else 'no grasps'}"
                except httpx.HTTPError as e:
                    ok, detail = False, f"{type(e).__name__}: {e}"
                dt = time.perf_counter() - t
                with lock:
                    counts[kind] += 1
                    if ok:
                        latencies.append(dt)
                    else:
                        counts["valid_lost"] += 1
                if not ok:
                    fail(f"{kind} lost: {detail}")

    def attacker(offset: int):
        attacks = hostile_requests(port)
        i = offset
        while not stop.is_set():
            name, thunk = attacks[i % len(attacks)]
            i += 1
            try:
                status = thunk()
            except OSError as e:
                status = f"error {type(e).__name__}"
            with lock:
                counts["hostile"] += 1
                hostile[name][status] += 1
            if status.startswith("5") or status in ("open", "garbled") or status.startswith("error"):
                fail(f"hostile {name}: {status}")

    def trickler():
        while not stop.is_set():
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
                    s.sendall(b"POST /process_npz HTTP/1.1\r\nHost: x\r\nContent-Length: 1000000\r\n\r\n")
                    while not stop.is_set():
                        s.sendall(b"x")
                        time.sleep(1.0)
            except OSError:
                with lock:
                    counts["trickle_cut_off"] += 1

    def health():
        with httpx.Client(timeout=5.0) as c:
            while not stop.is_set():
                t = time.perf_counter()
                try:
                    r = c.get(url + "/health")
                    ok = r.status_code == 200 and r.json()["status"] == "ok"
                    detail = f"HTTP {r.status_code}"
                except httpx.HTTPError as e:
                    ok, detail = False, f"{type(e).__name__}: {e}"
                dt = time.perf_counter() - t
                with lock:
                    counts["health_ok" if ok else "health_failed"] += 1
                    health_max[0] = max(health_max[0], dt)
                if not ok:
                    fail(f"health: {detail}")
                stop.wait(0.25)

    def memory():
        while not stop.is_set():
            rss_max[0] = max(rss_max[0], _rss_kb(server.pid))
            stop.wait(0.1)

    threads = [threading.Thread(target=valid, args=(b,)) for b in (True, True, False)]
    if not args.no_hostile:
        threads += [threading.Thread(target=attacker, args=(o,)) for o in (0, 6)]
        threads += [threading.Thread(target=trickler) for _ in range(8)]
    threads += [threading.Thread(target=health), threading.Thread(target=memory)]
    t0 = time.perf_counter()
    for t in threads:
        t.start()
    time.sleep(args.duration)
    stop.set()
    for t in threads:
        t.join(timeout=150)
    elapsed = time.perf_counter() - t0
    alive = server.poll() is None
    server.terminate()
    try:
        server.wait(timeout=10)
    except subprocess.TimeoutExpired:
        server.kill()

    lat = sorted(latencies)
    summary = {
        "duration_s": round(elapsed, 1),
        "valid_ok": len(lat),
        "valid_lost": counts["valid_lost"],
        "valid_npz": counts["valid_npz"],
        "valid_json": counts["valid_json"],
        "valid_p50_ms": round(1e3 * statistics.median(lat), 1) if lat else None,
        "valid_p95_ms": round(1e3 * lat[int(0.95 * (len(lat) - 1))], 1) if lat else None,
        "hostile": counts["hostile"],
        "hostile_statuses": {n: dict(c) for n, c in sorted(hostile.items())},
        "trickle_cut_off": counts["trickle_cut_off"],
        "health_ok": counts["health_ok"],
        "health_failed": counts["health_failed"],
        "health_max_ms": round(1e3 * health_max[0], 1),
        "rss_start_mb": round(rss_start / 1024, 1),
        "rss_max_mb": round(rss_max[0] / 1024, 1),
        "rss_limit_mb": args.rss_limit_mb,
        "server_alive": alive,
        "failures": failures,
    }
    summary["passed"] = (
        alive
        and not failures
        and summary["valid_ok"] > 0
        and summary["health_ok"] > 0
        and summary["rss_max_mb"] <= args.rss_limit_mb
    )
    print(json.dumps(summary, indent=2))
    if args.json:
        Path(args.json).write_text(json.dumps(summary, indent=2))
    return 0 if summary["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
