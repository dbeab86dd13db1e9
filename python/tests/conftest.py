"""Shared fixtures: the repository, the bundled scene and the `heliar` binary the Python API is
checked against (HELIAR_BIN, set by tools/pytest.sh; else target/debug/heliar)."""

import json
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCENE = REPO / "scenes" / "courtyard"

# Report fields that are times of this run, not results (they differ between any two runs).
TIMING_KEYS = {"estimate_ms", "sun_rebuild_ms", "decode_ms", "composite_ms", "encode_ms", "timings", "ms", "wall_s"}


def strip_timings(v):
    """A report value without its timing fields (the named ones and every `*_ms`), recursively."""
    if isinstance(v, dict):
        return {k: strip_timings(x) for k, x in v.items() if k not in TIMING_KEYS and not k.endswith("_ms")}
    if isinstance(v, list):
        return [strip_timings(x) for x in v]
    return v


@pytest.fixture(scope="session")
def heliar_bin() -> str:
    exe = os.environ.get("HELIAR_BIN") or str(REPO / "target" / "debug" / "heliar")
    if not Path(exe).is_file():
        pytest.fail(f"the heliar binary {exe} is missing: run tools/pytest.sh (it builds it) or set HELIAR_BIN")
    return exe


@pytest.fixture(scope="session")
def run_cli(heliar_bin):
    """Runs `heliar ARGS...`; returns the CompletedProcess (text)."""

    def run(*args, check=True):
        p = subprocess.run([heliar_bin, *map(str, args)], capture_output=True, text=True, stdin=subprocess.DEVNULL)
        if check and p.returncode != 0:
            raise AssertionError(f"heliar {' '.join(map(str, args))} exited {p.returncode}: {p.stderr[-2000:]}")
        return p

    return run


def read_jsonl(path: Path):
    return [json.loads(line) for line in Path(path).read_text().splitlines() if line.strip()]
