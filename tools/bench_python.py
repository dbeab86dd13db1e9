"""Measurements of issue 17 §3 (docs/measurements.md, "Python and Ray"):

1. the Python binding's overhead per frame against the command line: wall time of
   `Estimator.estimate` and `Compositor.composite` minus the library's own timers inside them
   (`estimate_ms`, `composite_ms` + relight), against the frame time of `heliar augment`;
2. throughput on the bundled HDR clip repeated REPEAT times: one `heliar augment` process, Ray
   with 1 worker and Ray with 2 workers (chunks of CHUNK frames), frames per second and the
   overhead per chunk (its wall time minus its frames at the one-process rate).

    target/venv/bin/python tools/bench_python.py [--repeat 4] [--chunk 12] [--heliar target/debug/heliar]
        [--scene DIR] [--frames N] [--fps F] [--warmup K] [--skip-binding] [--json OUT]

`--frames N` repeats the clip to N frames (instead of `--repeat`) at `--fps F` (default: the
sequence's own rate), so e.g. `--frames 1800 --fps 30` is a minute of 30 fps footage; `--scene`
takes another scene with an `hdr` sequence (e.g. the courtyard generated at 640×480 by
`gen-courtyard --width 640 --height 480`).
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import heliar
import heliar.ray as hray

def link_frames(src, dst):
    """Frames are hard-linked (read only); everything else is copied (the manifest is edited)."""
    if str(src).endswith((".exr", ".png")):
        os.link(src, dst)
    else:
        shutil.copy2(src, dst)


REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "scenes" / "courtyard"


def binding_overhead(args):
    scene = heliar.Scene.load(SCENE)
    est, comp = scene.estimator(sequence="hdr"), scene.compositor(sequence="hdr", samples=args.samples)
    files, times = scene.frame_files("hdr"), scene.frame_times("hdr")
    rows = []
    for rep in range(2):
        for path, t in zip(files, times):
            frame = heliar.read_frame(path)
            t0 = time.perf_counter()
            e = est.estimate(frame, t)
            t1 = time.perf_counter()
            _, report = comp.composite(frame, e)
            t2 = time.perf_counter()
            if rep == 1:  # the second pass: no first-frame traces
                inside = e.estimate_ms + report["composite_ms"] + report["relight"]["ms"]
                rows.append(((t2 - t0) * 1e3, inside, (t1 - t0) * 1e3 - e.estimate_ms))
        est = scene.estimator(sequence="hdr")  # the second pass starts the smoothing afresh
    wall = statistics.median(r[0] for r in rows)
    over = statistics.median(r[0] - r[1] for r in rows)
    return {"python_wall_ms_median": wall, "library_ms_median": statistics.median(r[1] for r in rows), "overhead_ms_median": over, "estimate_overhead_ms_median": statistics.median(r[2] for r in rows)}


def long_scene(tmp: Path, scene: Path, frames: int, fps: float, sequence: str = "hdr") -> tuple:
    """A copy of `scene` with a sequence `long`: the frames of its sequence `sequence` (`hdr`:
    EXR, `ldr`: PNG with that sequence's exposure) repeated to `frames` frames."""
    import tomllib

    root = tmp / "courtyard"
    shutil.copytree(scene, root, ignore=shutil.ignore_patterns("reference", "baked"), copy_function=link_frames)
    d = root / "frames" / "long"
    d.mkdir(parents=True)
    seq = next(q for q in tomllib.loads((scene / "scene.toml").read_text())["sequences"] if q["name"] == sequence)
    src = sorted(p for p in (scene / seq["dir"]).iterdir() if p.suffix in (".exr", ".png"))
    for k in range(frames):
        os.link(src[k % len(src)], d / f"frame_{k:06d}{src[k % len(src)].suffix}")
    exposure = f"exposure = {seq['exposure']}\n" if "exposure" in seq else ""
    with (root / "scene.toml").open("a") as f:
        f.write(f'\n[[sequences]]\nname = "long"\ndir = "frames/long"\nstart = "{seq["start"]}"\nfps = {fps}\n{exposure}')
    return root, d, frames


def throughput(args, exe):
    out = {}
    with tempfile.TemporaryDirectory(dir=REPO / "target") as tmp:
        tmp = Path(tmp)
        frames = args.frames or args.repeat * 12
        scene, clip, n = long_scene(tmp, Path(args.scene), frames, args.fps, args.sequence)
        extra = ["--samples", str(args.samples)]
        t0 = time.time()
        subprocess.run([exe, "bake", str(scene)], check=True, capture_output=True)
        out["bake_s"] = time.time() - t0
        out["frames"] = n
        env = dict(os.environ)
        if args.threads:
            env.update(RAYON_NUM_THREADS=str(args.threads), LP_NUM_THREADS=str(args.threads))
        one = args.one_wall_s
        if "one" in args.runs:
            t0 = time.time()
            subprocess.run([exe, "augment", str(scene), "--input", str(clip), "--output", str(tmp / "one"), *extra], check=True, capture_output=True, env=env)
            one = time.time() - t0
            out["one_process"] = {"wall_s": one, "fps": n / one, "summary": json.loads((tmp / "one" / "summary.json").read_text())}
            print(f"one process: {n} frames in {one:.1f} s, {n / one:.2f} frames/s", file=sys.stderr, flush=True)
        import ray

        for workers in (1, 2):
            if f"ray{workers}" not in args.runs:
                continue
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
            per_task = args.threads_per_task if workers > 1 else args.threads
            s = hray.augment(str(scene), [str(clip)], str(tmp / f"ray{workers}"), chunk_frames=args.chunk, warmup=args.warmup, extra_args=extra, heliar=exe, threads_per_task=per_task or 0, progress=False)
            ray.shutdown()
            per_frame = (one or float("nan")) / n
            overhead = [w - args.chunk * per_frame for w in s["chunk_wall_s"]]
            print(f"ray {workers}: {n / s['wall_s']:.2f} frames/s", file=sys.stderr, flush=True)
            out[f"ray_{workers}"] = {"wall_s": s["wall_s"], "fps": n / s["wall_s"], "chunks": s["chunks"], "bake_s": s["bake_s"], "merge_s": s["merge_s"], "chunk_wall_s": s["chunk_wall_s"], "overhead_per_chunk_s_median": statistics.median(overhead)}
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=4)
    ap.add_argument("--chunk", type=int, default=12)
    ap.add_argument("--samples", type=int, default=4)
    ap.add_argument("--heliar", default=None)
    ap.add_argument("--skip-ray", action="store_true")
    ap.add_argument("--skip-binding", action="store_true")
    ap.add_argument("--scene", default=str(SCENE), help="a scene with an `hdr` sequence (default: the bundled courtyard)")
    ap.add_argument("--frames", type=int, default=None, help="frames of the long clip (default: 12 × --repeat)")
    ap.add_argument("--fps", type=float, default=0.1, help="the long clip's frame rate (default 0.1, the bundled clip's)")
    ap.add_argument("--warmup", type=int, default=None, help="augment --warmup of the Ray chunks (default: all earlier frames)")
    ap.add_argument("--sequence", default="hdr", help="the scene's sequence to repeat (hdr: EXR frames; ldr: PNG frames)")
    ap.add_argument("--threads", type=int, default=1, help="RAYON_NUM_THREADS/LP_NUM_THREADS of the one process and of the 1-worker Ray tasks (default 1; 0: unset, all cores)")
    ap.add_argument("--threads-per-task", type=int, default=1, help="threads of each task of the 2-worker Ray run (default 1)")
    ap.add_argument("--runs", default="one,ray1,ray2", help="which throughput runs (comma-separated: one, ray1, ray2)")
    ap.add_argument("--one-wall-s", type=float, default=None, help="the one process's wall from an earlier run, for the overhead per chunk when `one` is not run")
    ap.add_argument("--json", default=None, help="also write the results here")
    args = ap.parse_args()
    exe = hray.find_heliar(args.heliar or str(REPO / "target" / "debug" / "heliar"))
    res = {"args": vars(args), "heliar": exe}
    if not args.skip_binding:
        res["binding"] = binding_overhead(args)
        print(json.dumps(res, indent=2), flush=True)
    if not args.skip_ray:
        res["throughput"] = throughput(args, exe)
    print(json.dumps(res, indent=2))
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=2) + "\n")


if __name__ == "__main__":
    sys.exit(main())
