"""`python -m heliar.ray augment` on a local Ray with two workers: three short clips (one of
them chunked) equal to sequential runs, a worker killed mid-chunk that is retried with nothing
lost or duplicated, and a second run that does nothing."""

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import heliar.ray as hray
from conftest import SCENE, read_jsonl, strip_timings

ray = pytest.importorskip("ray")

def link_frames(src, dst):
    """Frames are hard-linked (read only); everything else is copied (the manifest is edited)."""
    if str(src).endswith((".exr", ".png")):
        os.link(src, dst)
    else:
        shutil.copy2(src, dst)


# Faster than the defaults, identical between the chunks and the sequential runs.
FAST = ["--samples", "1", "--transfer-paths", "32"]
CHUNK = 4


@pytest.fixture(scope="module")
def ray_local():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


@pytest.fixture(scope="module")
def clips(tmp_path_factory):
    """A copy of the courtyard with three short sequences: 6 HDR frames (chunked 4 + 2),
    3 LDR frames and 3 later HDR frames."""
    root = tmp_path_factory.mktemp("scene") / "courtyard"
    shutil.copytree(SCENE, root, ignore=shutil.ignore_patterns("reference", "baked"), copy_function=link_frames)
    spans = {"a": ("hdr", range(0, 6), "15:30:00"), "b": ("ldr", range(0, 3), "15:30:00"), "c": ("hdr", range(6, 9), "15:31:00")}
    toml = (root / "scene.toml").read_text()
    for name, (src, frames, start) in spans.items():
        d = root / "frames" / name
        d.mkdir(parents=True)
        ext = "exr" if src == "hdr" else "png"
        for i in frames:
            os.link(SCENE / "frames" / src / f"frame_{i:03d}.{ext}", d / f"frame_{i:03d}.{ext}")
        exposure = "exposure = 3.5\n" if src == "ldr" else ""
        toml += f'\n[[sequences]]\nname = "{name}"\ndir = "frames/{name}"\nstart = "2024-06-21T{start}+02:00"\nfps = 0.1\n{exposure}'
    (root / "scene.toml").write_text(toml)
    return root, [root / "frames" / n for n in spans]


@pytest.fixture(scope="module")
def sequential(clips, run_cli, tmp_path_factory):
    """Each clip augmented by one plain `heliar augment` run."""
    scene, inputs = clips
    out = tmp_path_factory.mktemp("sequential")
    run_cli("bake", scene)
    for clip in inputs:
        run_cli("augment", scene, "--input", clip, "--output", out / clip.name, *FAST)
    return out


def assert_same_outputs(got: Path, want: Path):
    """The same frame files byte for byte, and the same report lines apart from timings."""
    files = sorted(p.name for p in want.iterdir() if p.suffix in (".png", ".exr") and p.name.startswith("frame_"))
    assert files and files == sorted(p.name for p in got.iterdir() if p.suffix in (".png", ".exr") and p.name.startswith("frame_"))
    for name in files:
        assert (got / name).read_bytes() == (want / name).read_bytes(), name
    a, b = read_jsonl(got / "report.jsonl"), read_jsonl(want / "report.jsonl")
    assert [line["frame"] for line in a] == [line["frame"] for line in b]  # no frame lost or repeated
    # The output paths differ by construction: compare their file names.
    assert [Path(x.pop("output")).name for x in a] == [Path(x.pop("output")).name for x in b]
    assert_same_lines(a, b)


def assert_same_lines(a, b):
    """Report lines (their `output` popped) equal apart from timings and work accounting."""
    # `passes.restored` names the work a chunk's (or a resumed run's) first frame did for the
    # replayed frames before it (absent in an uninterrupted run), and that frame's counts of
    # work done include it: bookkeeping of the run, not results (the frames are compared apart).
    for x, y in zip(a, b):
        if x["passes"].pop("restored", None) or y["passes"].pop("restored", None):
            for z in (x, y):
                z["passes"].pop("transfer_traced")
                z["passes"].pop("receivers_computed")
    assert [strip_timings(x) for x in a] == [strip_timings(x) for x in b]


def test_plan_chunks_the_long_clip_only(clips, tmp_path):
    scene, inputs = clips
    p = hray.plan(str(scene), [str(c) for c in inputs], str(tmp_path), CHUNK)
    assert [(c.clip, c.first, c.end, c.whole) for c in p.chunks] == [("a", 0, 4, False), ("a", 4, 6, False), ("b", 0, 3, True), ("c", 0, 3, True)]
    cmd = hray.augment_command("heliar", str(scene), p.chunks[1], None, FAST)
    assert cmd[cmd.index("--frames") + 1] == "4..6" and "--resume" in cmd


def test_ray_run_equals_sequential_and_a_second_run_does_nothing(ray_local, clips, sequential, heliar_bin, tmp_path):
    scene, inputs = clips
    out = tmp_path / "ray"
    s = hray.augment(str(scene), [str(c) for c in inputs], str(out), chunk_frames=CHUNK, extra_args=FAST, heliar=heliar_bin)
    assert (s["chunks"], s["chunks_run"], s["frames"], s["frames_this_run"]) == (4, 4, 12, 12)
    assert s["clips_merged"] == ["a"]
    for clip in inputs:
        assert_same_outputs(out / clip.name, sequential / clip.name)
    assert json.loads((out / "summary.json").read_text())["chunks"] == 4
    stamp = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p != out / "summary.json"}
    again = hray.augment(str(scene), [str(c) for c in inputs], str(out), chunk_frames=CHUNK, extra_args=FAST, heliar=heliar_bin)
    assert (again["chunks_run"], again["chunks_already_done"], again["frames_this_run"], again["clips_merged"]) == (0, 4, 0, [])
    assert {p: p.stat().st_mtime_ns for p in stamp} == stamp  # nothing rewritten


def test_a_worker_killed_mid_chunk_is_retried_without_loss(ray_local, clips, sequential, heliar_bin, tmp_path):
    scene, inputs = clips
    out = tmp_path / "killed"
    chunk = out / "chunks" / "a" / "000000-000004"
    result, killed = {}, {}

    def drive():
        result["summary"] = hray.augment(str(scene), [str(inputs[0])], str(out), chunk_frames=CHUNK, extra_args=FAST, heliar=heliar_bin, progress=False)

    t = threading.Thread(target=drive)
    t.start()
    deadline = time.time() + 600
    while time.time() < deadline and not killed:
        report = chunk / "report.jsonl"
        pid_file = chunk / hray.PID_FILE
        if report.is_file() and report.read_text().count("\n") >= 1 and pid_file.is_file() and not (chunk / "summary.json").exists():
            pid = int(pid_file.read_text())
            os.kill(pid, signal.SIGKILL)  # the Ray worker running the chunk: as if its machine died
            killed["pid"], killed["lines"] = pid, report.read_text().count("\n")
        time.sleep(0.02)
    t.join(timeout=900)
    assert killed, "the chunk finished before it could be killed"
    assert int((chunk / hray.PID_FILE).read_text()) != killed["pid"]  # another worker ran it again
    summary = json.loads((chunk / "summary.json").read_text())
    assert summary["resumed_after"] >= 1  # the retry continued after the frames written before the kill
    assert result["summary"]["chunks_run"] == 2
    assert_same_outputs(out / "a", sequential / "a")


def test_the_module_command_line(clips, sequential, heliar_bin, tmp_path):
    scene, inputs = clips
    out = tmp_path / "cli"
    env = dict(os.environ, HELIAR_BIN=heliar_bin)
    cmd = [sys.executable, "-m", "heliar.ray", "augment", str(scene), "--inputs", str(inputs[2]), "--output", str(out), "--chunk-frames", "2", "--no-progress", "--", *FAST]
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=900)
    assert p.returncode == 0, p.stderr[-3000:]
    s = json.loads(p.stdout)
    assert (s["chunks"], s["chunks_run"], s["frames"]) == (2, 2, 3)
    assert_same_outputs(out / "c", sequential / "c")


def test_a_video_clip_is_chunked_and_merged_into_the_sequential_video(ray_local, clips, run_cli, heliar_bin, tmp_path):
    """A video clip: counted by `heliar frames`, run as lossless .mkv chunks, merged by `heliar
    merge` into one video whose report equals a sequential run's (the frames' codes are compared
    by the Rust test augment_video::video_chunks_merge_into_the_sequential_video)."""
    scene, _ = clips
    footage = tmp_path / "street.mkv"  # any 320×240 video is footage: here the augmented LDR frames
    run_cli("augment", scene, "--input", scene / "frames" / "ldr", "--output", footage, "--max-frames", "6", *FAST)
    extra = [*FAST, "--start", "2024-06-21T15:30:00+02:00", "--exposure", "3.5"]
    want = tmp_path / "sequential.mkv"
    run_cli("augment", scene, "--input", footage, "--output", want, *extra)
    p = hray.plan(str(scene), [str(footage)], str(tmp_path / "ray"), CHUNK, heliar_bin)
    assert [(c.first, c.end, Path(c.out).name) for c in p.chunks] == [(0, 4, "000000-000004.mkv"), (4, 6, "000004-000006.mkv")]
    s = hray.augment(str(scene), [str(footage)], str(tmp_path / "ray"), chunk_frames=CHUNK, extra_args=extra, heliar=heliar_bin, progress=False)
    assert (s["chunks"], s["chunks_run"], s["frames"], s["clips_merged"]) == (2, 2, 6, ["street"])
    got = tmp_path / "ray" / "street.mkv"
    assert json.loads(run_cli("frames", got).stdout)["frames"] == 6
    a, b = read_jsonl(tmp_path / "ray" / "street.report.jsonl"), read_jsonl(tmp_path / "sequential.report.jsonl")
    assert [x.pop("output").split(" frame ")[1] for x in a] == [y.pop("output").split(" frame ")[1] for y in b]
    assert_same_lines(a, b)
    again = hray.augment(str(scene), [str(footage)], str(tmp_path / "ray"), chunk_frames=CHUNK, extra_args=extra, heliar=heliar_bin, progress=False)
    assert (again["chunks_run"], again["clips_merged"]) == (0, [])
