"""``python -m heliar.ray augment SCENE --inputs CLIP... --output DIR [--chunk-frames N]``."""

from __future__ import annotations

import argparse
import json
import sys

from . import ChunkFailed, augment


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m heliar.ray", description="heliar augment over many clips as Ray tasks")
    sub = ap.add_subparsers(dest="command", required=True)
    a = sub.add_parser("augment", help="augment clips in chunks on Ray (local, or the cluster of RAY_ADDRESS)")
    a.add_argument("scene", help="scene folder (read only; baked once before the tasks)")
    a.add_argument("--inputs", nargs="+", required=True, help="clips: folders of .png/.exr frames, or video files")
    a.add_argument("--output", required=True, help="output folder: DIR/CLIP per folder clip, DIR/CLIP.mkv (or the input's container) per video clip, DIR/summary.json")
    a.add_argument("--chunk-frames", type=int, default=None, help="frames per chunk (default: one chunk per clip)")
    a.add_argument("--warmup", type=int, default=None, help="frames replayed before a chunk (default: all before it: byte-identical to a sequential run)")
    a.add_argument("--heliar", default=None, help="the heliar binary (default: $HELIAR_BIN, else heliar on PATH)")
    a.add_argument("--max-retries", type=int, default=3, help="Ray task retries when a worker dies (default 3)")
    a.add_argument("--threads-per-task", type=int, default=1, help="RAYON_NUM_THREADS and LP_NUM_THREADS of each chunk (default 1; 0: unset)")
    a.add_argument("--no-progress", action="store_true", help="no progress bar")
    a.epilog = "Options after -- go to every `heliar augment` (e.g. -- --samples 1 --format png)."
    argv = list(sys.argv[1:] if argv is None else argv)
    extra = argv[argv.index("--") + 1 :] if "--" in argv else []
    args = ap.parse_args(argv[: argv.index("--")] if "--" in argv else argv)
    try:
        summary = augment(
            args.scene,
            args.inputs,
            args.output,
            chunk_frames=args.chunk_frames,
            warmup=args.warmup,
            extra_args=extra,
            heliar=args.heliar,
            max_retries=args.max_retries,
            threads_per_task=args.threads_per_task or None,
            progress=not args.no_progress,
        )
    except (ChunkFailed, FileNotFoundError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    short = {k: summary[k] for k in ("chunks", "chunks_run", "chunks_already_done", "frames", "frames_this_run", "wall_s", "frames_per_second")}
    print(json.dumps(short, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
