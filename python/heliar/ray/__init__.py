"""Many clips, many machines: ``heliar augment`` chunks as Ray tasks.

``python -m heliar.ray augment SCENE --inputs CLIP... --output DIR [--chunk-frames N]`` plans every
clip (a folder of frames, or a video file) as chunks of N frames, runs each chunk as one Ray task that calls
``heliar augment --frames A..B [--warmup K] --resume`` (the Rust command stays the single
implementation), merges each chunked clip with ``heliar merge`` and writes one summary.

- **Layout**: ``DIR/CLIP/`` holds each folder clip's frames, ``report.jsonl`` and ``summary.json``
  (the merged chunks, or the clip's own run when it is one chunk); chunks are written under
  ``DIR/chunks/CLIP/A-B/``; ``DIR/summary.json`` is the run's summary.
- **Video clips** (``.mp4``, ``.mkv``, …) are counted with ``heliar frames`` (decoded to the end),
  chunked into lossless ``DIR/chunks/CLIP/A-B.mkv`` videos and merged into one video
  ``DIR/CLIP.EXT`` (the input's container when heliar writes it, ``.mp4``/``.mkv``/``.avi``, else
  ``.mkv``), with ``CLIP.report.jsonl`` and ``CLIP.summary.json`` beside it.
- **Idempotent**: a chunk whose ``summary.json`` says it wrote all its frames (not interrupted,
  no error) gets a ``DONE`` marker and is never run again; an unfinished one is continued
  (``--resume``), so a re-run resumes and a second run of a finished job does nothing.
- **Failures**: a task whose worker dies is retried by Ray (``max_retries``); the ``heliar``
  process dies with its worker (``PR_SET_PDEATHSIG``) and the retry resumes the chunk.
- **Bake once**: the driver runs ``heliar bake SCENE`` before any task starts; the tasks find the
  cache fresh and only read the scene folder.
"""

from __future__ import annotations

import ctypes
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence

FRAME_EXTENSIONS = (".png", ".exr")
VIDEO_EXTENSIONS = (".mp4", ".mkv", ".avi", ".mov", ".webm", ".m4v", ".mpg", ".mpeg", ".ts")
WRITABLE_VIDEO = (".mp4", ".mkv", ".avi")
DONE_MARKER = "DONE"
PID_FILE = "worker.pid"


class ChunkFailed(RuntimeError):
    """A ``heliar augment`` chunk exited with an error (its message is the command's)."""


@dataclass(frozen=True)
class Chunk:
    """One ``heliar augment`` run: frames ``first..end`` of clip ``clip`` into ``out``."""

    clip: str
    input: str
    out: str
    first: int
    end: int
    whole: bool = False  # the clip in one run (no --frames, no merge)

    @property
    def frames(self) -> int:
        return self.end - self.first

    @property
    def name(self) -> str:
        return f"{self.clip}[{self.first}..{self.end})"


@dataclass
class Plan:
    """Every chunk of every clip, and where the clips end up."""

    scene: str
    output: str
    chunks: List[Chunk] = field(default_factory=list)
    clips: Dict[str, dict] = field(default_factory=dict)


def find_heliar(explicit: Optional[str] = None) -> str:
    """The ``heliar`` binary: ``explicit``, ``$HELIAR_BIN``, or ``heliar`` on ``PATH``."""
    for cand in (explicit, os.environ.get("HELIAR_BIN"), shutil.which("heliar")):
        if cand and Path(cand).is_file() and os.access(cand, os.X_OK):
            return str(Path(cand).resolve())
    raise FileNotFoundError(
        "the heliar binary was not found: give --heliar PATH, set HELIAR_BIN, or put heliar on PATH "
        "(cargo build --release puts it in target/release/heliar)"
    )


def is_video(path: Path) -> bool:
    """A video file by its extension (as ``heliar augment`` decides)."""
    return Path(path).suffix.lower() in VIDEO_EXTENSIONS


def summary_path(out: Path) -> Path:
    """An output's summary: inside a folder, beside a video (``OUT.summary.json``)."""
    out = Path(out)
    return out.with_name(out.stem + ".summary.json") if is_video(out) else out / "summary.json"


def marker_path(out: Path, name: str) -> Path:
    """A marker of an output (``DONE``, the worker's pid): inside a folder, beside a video."""
    out = Path(out)
    return out.with_name(f"{out.name}.{name}") if is_video(out) else out / name


def count_frames(clip: Path, heliar: Optional[str] = None) -> int:
    """Frames of a clip: a folder's ``.png``/``.exr`` files (as ``heliar augment`` lists them), or
    a video's decoded frames (``heliar frames CLIP``; needs the binary)."""
    clip = Path(clip)
    if clip.is_file() and is_video(clip):
        proc = subprocess.run([find_heliar(heliar), "frames", str(clip)], stdin=subprocess.DEVNULL, capture_output=True, text=True)
        if proc.returncode != 0:
            raise ValueError(proc.stderr.strip().removeprefix("error: ") or f"{clip}: heliar frames failed")
        n = int(json.loads(proc.stdout)["frames"])
        if n == 0:
            raise ValueError(f"{clip}: the video has no frames")
        return n
    if not clip.is_dir():
        raise ValueError(f"{clip}: neither a folder of frames nor a video file ({', '.join(VIDEO_EXTENSIONS)})")
    n = sum(1 for p in clip.iterdir() if p.suffix.lower() in FRAME_EXTENSIONS and p.is_file())
    if n == 0:
        raise ValueError(f"{clip}: no .png or .exr frames")
    return n


def clip_names(inputs: Sequence[str]) -> List[str]:
    """A distinct output name per clip: the folder's name, numbered when names repeat."""
    names: List[str] = []
    for p in inputs:
        path = Path(p).resolve()
        base = (path.stem if is_video(path) else path.name) or "clip"
        name, k = base, 2
        while name in names:
            name, k = f"{base}-{k}", k + 1
        names.append(name)
    return names


def plan(scene: str, inputs: Sequence[str], output: str, chunk_frames: Optional[int] = None, heliar: Optional[str] = None) -> Plan:
    """Splits every clip into chunks of ``chunk_frames`` (default: one chunk per clip). Video clips
    are counted with the ``heliar`` binary (see :func:`count_frames`)."""
    if chunk_frames is not None and chunk_frames < 1:
        raise ValueError(f"--chunk-frames {chunk_frames}: must be at least 1")
    out = Path(output).resolve()
    p = Plan(scene=str(Path(scene).resolve()), output=str(out))
    for clip, name in zip(inputs, clip_names(inputs)):
        path = Path(clip).resolve()
        n = count_frames(path, heliar)
        size = chunk_frames or n
        video = is_video(path)
        ext = path.suffix.lower() if path.suffix.lower() in WRITABLE_VIDEO else ".mkv"
        target = out / f"{name}{ext}" if video else out / name
        if n <= size:
            p.chunks.append(Chunk(name, str(path), str(target), 0, n, whole=True))
            p.clips[name] = {"input": str(path), "frames": n, "output": str(target), "chunks": 1}
            continue
        k = 0
        for a in range(0, n, size):
            b = min(a + size, n)
            folder = out / "chunks" / name / f"{a:06d}-{b:06d}"
            # Lossless chunks: the merge decodes them, so they must not lose anything.
            p.chunks.append(Chunk(name, str(path), str(folder.with_name(folder.name + ".mkv") if video else folder), a, b))
            k += 1
        p.clips[name] = {"input": str(path), "frames": n, "output": str(target), "chunks": k}
    return p


def read_summary(out: Path) -> Optional[dict]:
    """The summary of an output folder or video, if it is readable."""
    try:
        return json.loads(summary_path(out).read_text())
    except (OSError, ValueError):
        return None


def finished(chunk: Chunk) -> bool:
    """True when the chunk's output is complete: its marker, or a summary that says so."""
    out = Path(chunk.out)
    if marker_path(out, DONE_MARKER).is_file():
        return True
    s = read_summary(out)
    return bool(s) and s.get("frames_written") == chunk.frames and not s.get("interrupted") and not s.get("error")


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(text)
    os.replace(tmp, path)


def _die_with_parent() -> None:
    """In the child: SIGKILL when the worker that started it dies (Linux ``PR_SET_PDEATHSIG``)."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG = 1
    except OSError:
        pass


def augment_command(heliar: str, scene: str, chunk: Chunk, warmup: Optional[int], extra: Sequence[str]) -> List[str]:
    """The ``heliar augment`` command line of one chunk (what a Job or Slurm array runs too)."""
    cmd = [heliar, "augment", scene, "--input", chunk.input, "--output", chunk.out, "--resume"]
    if not chunk.whole:
        cmd += ["--frames", f"{chunk.first}..{chunk.end}"]
        if warmup is not None:
            cmd += ["--warmup", str(warmup)]
    return cmd + list(extra)


def run_chunk(heliar: str, scene: str, chunk: Chunk, warmup: Optional[int], extra: Sequence[str], threads: Optional[int]) -> dict:
    """Runs one chunk unless it is finished; returns what happened (the body of the Ray task)."""
    out = Path(chunk.out)
    if finished(chunk):
        return {"chunk": asdict(chunk), "ran": False}
    (out.parent if is_video(out) else out).mkdir(parents=True, exist_ok=True)
    _write_atomic(marker_path(out, PID_FILE), f"{os.getpid()}\n")
    env = dict(os.environ)
    if threads:
        env.setdefault("RAYON_NUM_THREADS", str(threads))
        env.setdefault("LP_NUM_THREADS", str(threads))
    t0 = time.time()
    proc = subprocess.run(
        augment_command(heliar, scene, chunk, warmup, extra),
        env=env,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_die_with_parent,
        start_new_session=True,  # no controlling terminal: never stopped by terminal job control
    )
    wall = time.time() - t0
    if proc.returncode != 0:
        tail = "\n".join(proc.stderr.strip().splitlines()[-5:])
        raise ChunkFailed(f"chunk {chunk.name}: heliar augment exited with {proc.returncode}: {tail}")
    if not finished(chunk):
        raise ChunkFailed(f"chunk {chunk.name}: heliar augment ended without writing its {chunk.frames} frames ({summary_path(out)})")
    _write_atomic(marker_path(out, DONE_MARKER), json.dumps({"frames": [chunk.first, chunk.end], "wall_s": wall}) + "\n")
    s = read_summary(out) or {}
    return {"chunk": asdict(chunk), "ran": True, "wall_s": wall, "frames_this_run": s.get("frames_this_run", 0)}


def merge_clip(heliar: str, p: Plan, name: str) -> bool:
    """Merges a chunked clip's chunks into ``DIR/CLIP`` unless that is done; True when merged."""
    info = p.clips[name]
    target = Path(info["output"])
    s = read_summary(target)
    if marker_path(target, DONE_MARKER).is_file() and s and s.get("frames_written") == info["frames"]:
        return False
    dirs = [c.out for c in p.chunks if c.clip == name]
    proc = subprocess.run([heliar, "merge", *dirs, "--output", str(target)], stdin=subprocess.DEVNULL, capture_output=True, text=True)
    if proc.returncode != 0:
        raise ChunkFailed(f"merging {name}: {proc.stderr.strip()}")
    _write_atomic(marker_path(target, DONE_MARKER), json.dumps({"frames": [0, info["frames"]], "chunks": len(dirs)}) + "\n")
    return True


def bake(heliar: str, scene: str) -> None:
    """``heliar bake SCENE`` once, before the tasks (returns at once when the cache is fresh)."""
    proc = subprocess.run([heliar, "bake", scene], stdin=subprocess.DEVNULL, capture_output=True, text=True)
    if proc.returncode != 0:
        raise ChunkFailed(f"baking {scene}: {proc.stderr.strip()}")


class Progress:
    """A progress bar over chunks on stderr (a line per update when stderr is not a terminal)."""

    def __init__(self, total: int, enabled: bool = True):
        self.total, self.done, self.skipped, self.t0 = total, 0, 0, time.time()
        self.enabled = enabled
        self.tty = sys.stderr.isatty()

    def update(self, ran: bool) -> None:
        self.done += 1
        self.skipped += 0 if ran else 1
        if not self.enabled:
            return
        width = 30
        filled = int(width * self.done / max(self.total, 1))
        bar = "=" * filled + " " * (width - filled)
        line = f"chunks [{bar}] {self.done}/{self.total} ({self.skipped} already done), {time.time() - self.t0:.0f} s"
        sys.stderr.write(("\r" + line) if self.tty else (line + "\n"))
        sys.stderr.flush()

    def close(self) -> None:
        if self.enabled and self.tty:
            sys.stderr.write("\n")


def augment(
    scene: str,
    inputs: Sequence[str],
    output: str,
    chunk_frames: Optional[int] = None,
    warmup: Optional[int] = None,
    extra_args: Sequence[str] = (),
    heliar: Optional[str] = None,
    max_retries: int = 3,
    threads_per_task: Optional[int] = 1,
    progress: bool = True,
) -> dict:
    """Runs every clip's chunks as Ray tasks (``ray.init()`` first when Ray is not started:
    local, or the cluster of ``RAY_ADDRESS``), merges the chunked clips and writes
    ``output/summary.json``. Returns that summary."""
    import ray

    exe = find_heliar(heliar)
    p = plan(scene, inputs, output, chunk_frames, exe)
    Path(p.output).mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    bake(exe, p.scene)
    bake_s = time.time() - t0
    if not ray.is_initialized():
        ray.init()
    task = ray.remote(num_cpus=1, max_retries=max_retries)(run_chunk)
    pending = {task.remote(exe, p.scene, c, warmup, list(extra_args), threads_per_task): c for c in p.chunks}
    bar = Progress(len(pending), progress)
    results: List[dict] = []
    try:
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                pending.pop(ref)
                r = ray.get(ref)
                results.append(r)
                bar.update(r["ran"])
    finally:
        bar.close()
    t1 = time.time()
    merged = [name for name, info in p.clips.items() if info["chunks"] > 1 and merge_clip(exe, p, name)]
    merge_s = time.time() - t1
    summary = _summary(p, results, merged, bake_s, merge_s, time.time() - t0)
    _write_atomic(Path(p.output) / "summary.json", json.dumps(summary, indent=2) + "\n")
    return summary


def _summary(p: Plan, results: List[dict], merged: List[str], bake_s: float, merge_s: float, wall_s: float) -> dict:
    ran = [r for r in results if r["ran"]]
    frames_this_run = sum(r.get("frames_this_run", 0) for r in ran)
    clips = {}
    for name, info in p.clips.items():
        s = read_summary(Path(info["output"])) or {}
        clips[name] = {**info, "frames_written": s.get("frames_written"), "statuses": s.get("counts", {}).get("statuses")}
    return {
        "scene": p.scene,
        "clips": clips,
        "chunks": len(results),
        "chunks_run": len(ran),
        "chunks_already_done": len(results) - len(ran),
        "clips_merged": merged,
        "frames": sum(info["frames"] for info in p.clips.values()),
        "frames_this_run": frames_this_run,
        "wall_s": wall_s,
        "bake_s": bake_s,
        "merge_s": merge_s,
        "chunk_wall_s": [r["wall_s"] for r in ran],
        "frames_per_second": frames_this_run / wall_s if wall_s > 0 else 0.0,
    }
