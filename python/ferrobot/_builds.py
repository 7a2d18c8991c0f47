"""Chooses which build of the extension module ``ferrobot._core`` this process runs.

A wheel built by ``scripts/build_wheel.py`` holds the whole extension compiled several times, once per
instruction-set level: the architecture's baseline as ``ferrobot/_core.<abi>.so`` (x86-64: SSE2; aarch64:
NEON, every aarch64 CPU has it) and, on x86-64, ``ferrobot/_simd/<level>/_core.<abi>.so`` for ``x86-64-v2``
(SSE4.2), ``x86-64-v3`` (AVX2, FMA) and ``x86-64-v4`` (AVX-512). Every build is complete (nalgebra, parry,
kiddo and ferrobot's own kernels all use that level's instructions), and every build gives the same answers.
``import ferrobot`` imports this module first: it asks the baseline build (always loadable) which level the
CPU and OS support, loads the best build at or below it and registers it as ``ferrobot._core``, before
anything else imports ``ferrobot._core``. A source install (``pip install .``) holds one build, compiled
for the machine that built it, and loads it unchanged.

``FERROBOT_SIMD`` (``baseline``, ``x86-64-v2``, ``x86-64-v3``, ``x86-64-v4``; ``v2``, ``v3``, ``v4`` also
accepted) forces a level. The environment variable is then rewritten to the canonical name, which the
collision kernels' own run-time dispatch (``crates/ferrobot-collision/src/dispatch.rs``) reads as its cap,
so both layers run the same level. Forcing a level raises :class:`ferrobot.errors.InvalidArgumentError`
when the name is unknown, when the CPU lacks the level, or when this install has no build for it (a
source install holds only its own build: forcing any other level cannot be honoured).
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import os
import sys
from pathlib import Path
from types import ModuleType

from .errors import InvalidArgumentError

#: The levels, from the baseline up (names as ``FERROBOT_SIMD`` and ``dispatch.rs`` spell them).
LEVELS = ("baseline", "x86-64-v2", "x86-64-v3", "x86-64-v4")
_ALIASES = {"v1": "baseline", "x86-64": "baseline", "v2": "x86-64-v2", "v3": "x86-64-v3", "v4": "x86-64-v4"}
#: Where a wheel keeps its per-level builds, relative to the package: ``_simd/<level>/_core<suffix>``.
SIMD_DIR = "_simd"

_state: dict[str, object] = {}


def canonical_level(name: str) -> str:
    """The canonical name of a level given as ``FERROBOT_SIMD`` accepts it (case and spaces ignored)."""
    key = name.strip().lower()
    key = _ALIASES.get(key, key)
    if key not in LEVELS:
        raise InvalidArgumentError(
            f"FERROBOT_SIMD={name!r} is not an instruction-set level; use one of {', '.join(LEVELS)} "
            "(or v2, v3, v4), or unset it to use the best level this CPU supports"
        )
    return key


def available_builds(package_dir: Path) -> dict[str, Path]:
    """The per-level builds a wheel holds beside its baseline build: level -> file (empty for a source install)."""
    out: dict[str, Path] = {}
    for level in LEVELS[1:]:
        d = package_dir / SIMD_DIR / level
        for suffix in importlib.machinery.EXTENSION_SUFFIXES:
            f = d / f"_core{suffix}"
            if f.is_file():
                out[level] = f
                break
    return out


def choose_level(requested: str | None, cpu: str, builds: list[str], single_build: str | None = None) -> str:
    """The level to load.

    ``requested``: ``FERROBOT_SIMD`` or None; ``cpu``: the best level the CPU supports; ``builds``: the levels
    this install has a build for, baseline included; ``single_build``: for an install holding only one build
    (a source install), the level it was compiled for. Raises :class:`InvalidArgumentError` for an unknown
    name, a level the CPU lacks, or a level this install cannot load.
    """
    cpu = canonical_level(cpu)
    if requested is None:
        if single_build is not None:
            return canonical_level(single_build)
        return max((b for b in builds if LEVELS.index(b) <= LEVELS.index(cpu)), key=LEVELS.index)
    level = canonical_level(requested)
    if LEVELS.index(level) > LEVELS.index(cpu):
        raise InvalidArgumentError(
            f"FERROBOT_SIMD={requested!r}: this CPU does not support {level} (its best level is {cpu}); "
            "unset FERROBOT_SIMD or choose a level at or below that"
        )
    if single_build is not None:
        if level != canonical_level(single_build):
            raise InvalidArgumentError(
                f"FERROBOT_SIMD={requested!r}: this install holds a single build of the extension, compiled for "
                f"{single_build} (a source install, built for its machine), so {level} cannot be loaded; "
                "use a wheel built by scripts/build_wheel.py, or unset FERROBOT_SIMD"
            )
        return level
    if level not in builds:
        raise InvalidArgumentError(
            f"FERROBOT_SIMD={requested!r}: this install has no build for {level} (it has {', '.join(builds)})"
        )
    return level


def _load_file(path: Path) -> ModuleType:
    loader = importlib.machinery.ExtensionFileLoader("ferrobot._core", str(path))
    spec = importlib.util.spec_from_file_location("ferrobot._core", str(path), loader=loader)
    assert spec is not None
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def load_core() -> ModuleType:
    """Loads the chosen build as ``ferrobot._core`` (once per process) and returns it."""
    if "ferrobot._core" in sys.modules and "level" in _state:
        return sys.modules["ferrobot._core"]
    package = sys.modules[__package__]
    package_dir = Path(__file__).resolve().parent
    spec = importlib.util.find_spec("ferrobot._core")
    if spec is None or spec.origin is None:
        raise ImportError("ferrobot._core, the compiled extension, is not installed")
    base = _load_file(Path(spec.origin))  # the baseline build of a wheel, or a source install's only build
    cpu, built = base._simd_support()
    extra = available_builds(package_dir)
    requested = os.environ.get("FERROBOT_SIMD")
    if extra:
        level = choose_level(requested, cpu, ["baseline", *extra])
        module = base if level == "baseline" else _load_file(extra[level])
        path = Path(spec.origin) if level == "baseline" else extra[level]
    else:
        level = choose_level(requested, cpu, [built], single_build=built)
        module, path = base, Path(spec.origin)
    if requested is not None:
        os.environ["FERROBOT_SIMD"] = level  # the collision kernels' dispatch caps itself at the same level
    sys.modules["ferrobot._core"] = module
    package._core = module
    _state.update(
        level=level, cpu=cpu, path=str(path), builds=["baseline", *extra] if extra else [built], forced=requested
    )
    return module


def simd_level() -> str:
    """The instruction-set level of the loaded extension build (``baseline``, ``x86-64-v2``/``v3``/``v4``).

    For a source install this is the highest level whose features all the compiler enabled (its build for
    the host CPU may use more, e.g. ``x86-64-v4`` on an AVX-512 machine).
    """
    return str(_state["level"])


def simd_info() -> dict[str, object]:
    """Which build was loaded and why: ``level``, ``cpu`` (the best level the CPU supports), ``path`` (the
    loaded file), ``builds`` (the levels this install holds; one entry for a source install),
    ``forced`` (``FERROBOT_SIMD`` as set at import, or None)."""
    return dict(_state)


load_core()
