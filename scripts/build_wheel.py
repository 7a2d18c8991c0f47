"""Builds one portable wheel holding the extension compiled once per instruction-set level (issue 22).

    python scripts/build_wheel.py [--out DIR] [--levels baseline x86-64-v3 ...] [--no-auditwheel]
                                  [--repair] [--target-dir-template T] [-- MATURIN_ARGS...]

For each level it runs ``maturin build --release`` with ``RUSTFLAGS="-C target-cpu=<level>"`` (which replaces
the ``target-cpu=native`` of ``.cargo/config.toml``; any ``RUSTFLAGS`` you set are kept, ``target-cpu``
excepted) in its own cargo target directory (so rebuilding one level does not invalidate another), then
takes the baseline wheel and adds the other levels' extension files as
``ferrobot/_simd/<level>/_core.<abi>.so`` (``.pyd`` on Windows), rewriting the wheel's RECORD. At import,
``ferrobot/_builds.py`` loads the best build the CPU supports. x86-64 builds ``baseline`` (SSE2),
``x86-64-v2``, ``x86-64-v3`` and ``x86-64-v4``; other architectures only their baseline (aarch64's includes
NEON), with the target's default CPU.

On Linux the result is checked with ``auditwheel show`` (every build must link only what the manylinux
policy allows); ``--repair`` also runs ``auditwheel repair`` into ``OUT/repaired/``. Arguments after ``--``
go to every ``maturin build`` (e.g. ``-- -i python3.12 --compatibility manylinux2014 --zig`` or
``-- --target aarch64-unknown-linux-gnu --zig``).
"""

from __future__ import annotations

import argparse
import base64
import hashlib
import os
import platform
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
X86_LEVELS = ("baseline", "x86-64-v2", "x86-64-v3", "x86-64-v4")
TARGET_CPU = {"x86-64-v2": "x86-64-v2", "x86-64-v3": "x86-64-v3", "x86-64-v4": "x86-64-v4"}


def target_arch(maturin_args: list[str]) -> str:
    """The architecture being built for: from ``--target TRIPLE`` if given, else this machine's."""
    for i, a in enumerate(maturin_args):
        if a == "--target" and i + 1 < len(maturin_args):
            return maturin_args[i + 1].split("-")[0]
        if a.startswith("--target="):
            return a.split("=", 1)[1].split("-")[0]
    m = platform.machine().lower()
    return {"amd64": "x86_64", "x64": "x86_64", "arm64": "aarch64"}.get(m, m)


def rustflags_for(level: str, arch: str) -> str:
    """The user's RUSTFLAGS without any target-cpu, plus this level's (baseline x86-64: ``x86-64``)."""
    words = shlex.split(os.environ.get("RUSTFLAGS", ""))
    kept: list[str] = []
    skip = False
    for i, w in enumerate(words):
        if skip:
            skip = False
            continue
        if w.startswith("-Ctarget-cpu=") or w.startswith("target-cpu="):
            continue
        if w == "-C" and i + 1 < len(words) and words[i + 1].startswith("target-cpu="):
            skip = True
            continue
        kept.append(w)
    if arch == "x86_64":
        kept += ["-C", f"target-cpu={TARGET_CPU.get(level, 'x86-64')}"]
    # other architectures: the target's default CPU (aarch64: generic, with NEON; macOS: apple-m1)
    return " ".join(kept)


def maturin_cmd() -> list[str]:
    exe = shutil.which("maturin")
    return [exe] if exe else [sys.executable, "-m", "maturin"]


def build_level(level: str, arch: str, out: Path, target_dir: Path, maturin_args: list[str]) -> list[Path]:
    env = dict(os.environ, RUSTFLAGS=rustflags_for(level, arch), CARGO_TARGET_DIR=str(target_dir))
    env.pop("CARGO_ENCODED_RUSTFLAGS", None)  # it would take precedence over RUSTFLAGS
    cmd = [*maturin_cmd(), "build", "--release", "--out", str(out), *maturin_args]
    print(f"[build_wheel] {level}: RUSTFLAGS={env['RUSTFLAGS']!r} CARGO_TARGET_DIR={target_dir}", flush=True)
    print(f"[build_wheel] {shlex.join(cmd)}", flush=True)
    t0 = time.monotonic()
    subprocess.run(cmd, cwd=ROOT, env=env, check=True)
    print(f"[build_wheel] {level} built in {time.monotonic() - t0:.0f} s", flush=True)
    return sorted(out.glob("*.whl"))


def _is_extension(name: str) -> bool:
    base = name.rsplit("/", 1)[-1]
    return (
        name.startswith("ferrobot/")
        and name.count("/") == 1
        and base.startswith("_core.")
        and (base.endswith(".so") or base.endswith(".pyd"))
    )


def _record_line(name: str, data: bytes) -> str:
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def assemble(base_wheel: Path, variants: dict[str, Path], out: Path) -> Path:
    """``base_wheel`` plus each variant wheel's extension file under ``ferrobot/_simd/<level>/``, RECORD rewritten."""
    extra: list[tuple[zipfile.ZipInfo, str, bytes]] = []
    for level, wheel in variants.items():
        with zipfile.ZipFile(wheel) as z:
            ext = [i for i in z.infolist() if _is_extension(i.filename)]
            if len(ext) != 1:
                raise SystemExit(f"{wheel}: expected one ferrobot/_core extension file, found {len(ext)}")
            info = ext[0]
            name = f"ferrobot/_simd/{level}/{info.filename.split('/', 1)[1]}"
            extra.append((info, name, z.read(info)))
    target = out / base_wheel.name
    tmp = target.with_suffix(".tmp")
    records: list[str] = []
    with zipfile.ZipFile(base_wheel) as src, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
        record_name = next(n for n in src.namelist() if n.endswith(".dist-info/RECORD"))
        for info in src.infolist():
            if info.filename == record_name:
                continue
            data = src.read(info)
            dst.writestr(info, data, compress_type=zipfile.ZIP_DEFLATED)
            records.append(_record_line(info.filename, data))
        for info, name, data in extra:
            zi = zipfile.ZipInfo(name, date_time=info.date_time)
            zi.external_attr = info.external_attr  # keep the executable bits of the shared library
            dst.writestr(zi, data, compress_type=zipfile.ZIP_DEFLATED)
            records.append(_record_line(name, data))
        records.append(f"{record_name},,")
        record = zipfile.ZipInfo(record_name, date_time=src.getinfo(record_name).date_time)
        dst.writestr(record, "\n".join(records) + "\n", compress_type=zipfile.ZIP_DEFLATED)
    tmp.replace(target)
    return target


def main() -> int:
    argv = sys.argv[1:]
    maturin_args: list[str] = []
    if "--" in argv:
        k = argv.index("--")
        argv, maturin_args = argv[:k], argv[k + 1 :]
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "dist", help="where the wheel goes (default dist/)")
    ap.add_argument("--levels", nargs="+", help="levels to build (default: all of the architecture's)")
    ap.add_argument(
        "--target-dir-template",
        default=str(Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "simd-{level}"),
        help="cargo target directory per level, with {level} (default $CARGO_TARGET_DIR/simd-{level})",
    )
    ap.add_argument("--no-auditwheel", action="store_true", help="skip `auditwheel show` (Linux only anyway)")
    ap.add_argument("--repair", action="store_true", help="also run `auditwheel repair -w OUT/repaired` (Linux)")
    args = ap.parse_args(argv)

    arch = target_arch(maturin_args)
    levels = args.levels or (list(X86_LEVELS) if arch == "x86_64" else ["baseline"])
    if "baseline" not in levels:
        raise SystemExit("--levels must include baseline: it is the build every CPU loads, and the loader's probe")
    unknown = [lv for lv in levels if lv not in X86_LEVELS]
    if unknown or (arch != "x86_64" and levels != ["baseline"]):
        raise SystemExit(f"levels {levels} are not valid for {arch} (x86_64: {', '.join(X86_LEVELS)}; else baseline)")
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="ferrobot-wheels-") as tmpd:
        built: dict[str, list[Path]] = {}
        for level in ["baseline", *[lv for lv in levels if lv != "baseline"]]:
            td = Path(args.target_dir_template.format(level=level))
            built[level] = build_level(level, arch, Path(tmpd) / level, td, maturin_args)
        results = []
        for base in built["baseline"]:
            variants = {}
            for level in levels:
                if level == "baseline":
                    continue
                match = [w for w in built[level] if w.name == base.name]
                if not match:
                    raise SystemExit(f"{level}: no wheel named {base.name} (got {[w.name for w in built[level]]})")
                variants[level] = match[0]
            results.append(assemble(base, variants, args.out))
    for w in results:
        print(f"[build_wheel] wrote {w} ({w.stat().st_size / 1e6:.1f} MB): baseline + {', '.join(levels[1:]) or '-'}")
        if sys.platform.startswith("linux") and "linux" in w.name and not args.no_auditwheel:
            subprocess.run([sys.executable, "-m", "auditwheel", "show", str(w)], check=True)
            if args.repair:
                repaired = str(args.out / "repaired")  # same file name as the input: another folder
                subprocess.run([sys.executable, "-m", "auditwheel", "repair", "-w", repaired, str(w)], check=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
