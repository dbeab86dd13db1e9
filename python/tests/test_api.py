"""The Python API against the command line on the bundled courtyard: the same estimates (the
JSON lines of `heliar estimate`), the same composited frames (the EXR and PNG files of
`heliar augment`), the same solar positions and error messages."""

import json
import math

import numpy as np
import pytest

import heliar
from conftest import SCENE, read_jsonl, strip_timings

# The CLI's report line has these beside the estimate (file fields, not the estimator's).
CLI_ONLY = {"truth", "error", "decode_ms"}


@pytest.fixture(scope="module")
def scene():
    return heliar.Scene.load(SCENE)


def test_scene_loads_with_its_sequences(scene):
    assert scene.sequences == ["hdr", "ldr"]
    assert (scene.width, scene.height) == (320, 240)
    assert len(scene.frame_files("hdr")) == len(scene.frame_times("hdr")) == 12
    assert scene.frame_times("hdr")[0] == "2024-06-21T15:30:00+02:00"


@pytest.mark.parametrize("sequence", ["hdr", "ldr"])
def test_estimates_equal_the_cli_json_lines(scene, run_cli, tmp_path, sequence):
    out = tmp_path / "est.jsonl"
    run_cli("estimate", SCENE, "--sequence", sequence, "--output", out)
    cli = read_jsonl(out)
    est = scene.estimator(sequence=sequence)
    files, times = scene.frame_files(sequence), scene.frame_times(sequence)
    assert len(cli) == len(files)
    for path, time, line in zip(files, times, cli):
        frame = heliar.read_frame(path)
        assert frame.dtype == (np.float32 if sequence == "hdr" else np.uint8)
        e = est.estimate(frame, time)
        want = strip_timings({k: v for k, v in line.items() if k not in CLI_ONLY})
        # Same code, same frame, same draw: equal to the last digit JSON prints.
        assert strip_timings(e.to_dict()) == want
        assert (list(e.pd) if e.pd else None) == line["pd"]
        assert e.status == line["status"]
        assert e.condition_number == line["condition_number"]
        assert list(e.pa_se) == line["pa_se"]


def test_estimate_fields_and_json(scene):
    est = scene.estimator(sequence="hdr")
    e = est.estimate(heliar.read_frame(scene.frame_files("hdr")[0]), scene.frame_times("hdr")[0])
    assert e.frame == 0 and est.next_index == 1
    assert e.status in {"ok", "sun_not_separable", "no_direct_sun", "night", "too_few_samples", "saturated", "dark_frame"}
    assert len(e.pd) == 3 and len(e.pa) == 3 and all(v > 0 for v in e.pa)
    assert all(se >= 0 for se in e.pd_se)
    assert e.condition_number >= 1.0  # a condition number is at least 1
    assert math.isclose(sum(c * c for c in e.sun["dir_world"]), 1.0, rel_tol=1e-5)
    assert json.loads(e.to_json())["frame"] == 0
    assert "Estimate(frame=0" in repr(e)


@pytest.mark.parametrize("sequence,fmt", [("hdr", "exr"), ("ldr", "png")])
def test_composited_frames_equal_the_cli_files(scene, run_cli, tmp_path, sequence, fmt):
    frames = 2
    out = tmp_path / "aug"
    run_cli("augment", SCENE, "--input", SCENE / "frames" / sequence, "--output", out, "--max-frames", frames)
    lines = read_jsonl(out / "report.jsonl")
    est, comp = scene.estimator(sequence=sequence), scene.compositor(sequence=sequence)
    for i, (path, time) in enumerate(list(zip(scene.frame_files(sequence), scene.frame_times(sequence)))[:frames]):
        frame = heliar.read_frame(path)
        e = est.estimate(frame, time)
        image, report = comp.composite(frame, e, time)
        assert image.shape == frame.shape and image.dtype == frame.dtype
        cli = heliar.read_frame(out / f"frame_{i:03d}.{fmt}")
        if fmt == "exr":
            # The CLI writes half floats: the same values rounded to half, bit for bit.
            assert np.array_equal(image.astype(np.float16), cli.astype(np.float16))
        else:
            assert np.array_equal(image, cli)
        assert not np.array_equal(image, frame), "the statue must change some pixels"
        line = lines[i]
        passes = {k: v for k, v in report.items() if k not in ("relight", "composite_ms")}
        assert strip_timings(passes) == strip_timings(line["passes"])
        assert report["relight"]["ran"] == line["relight"]["ran"]
        assert (e.status, e.condition_number) == (line["status"], line["condition_number"])
        # The report's pd/pa are the lighting the compositor used: the smoothed values, in f32.
        assert np.array_equal(np.float32(e.smoothed["pd"]), np.float32(line["pd"]))
        assert np.array_equal(np.float32(e.smoothed["pa"]), np.float32(line["pa"]))


def test_composite_with_explicit_lighting(scene):
    comp = scene.compositor(sequence="hdr", samples=1, transfer_paths=0, ambient="uniform")
    frame = heliar.read_frame(scene.frame_files("hdr")[0])
    sun = scene.sun(scene.frame_times("hdr")[0])["dir_world"]
    lit, rep = comp.composite(frame, heliar.Lighting(sun, (3.0, 3.0, 3.0), (1.0, 1.0, 1.0)))
    dark, rep2 = comp.composite(frame, heliar.Lighting(sun, (0.0, 0.0, 0.0), (0.2, 0.2, 0.2)))
    assert rep["relight"]["ran"] and rep2["relight"]["ran"]
    changed = np.any(lit != frame, axis=2)
    # Brighter light makes the virtual object brighter where it is drawn.
    assert changed.sum() > 100
    assert lit[changed].mean() > dark[changed].mean()


def test_sun_equals_the_cli(run_cli):
    args = dict(lat=57.0488, lon=9.9217, time="2024-06-21T15:30:00+02:00")
    cli = json.loads(run_cli("sun", "--lat", args["lat"], "--lon", args["lon"], "--time", args["time"]).stdout)
    py = heliar.sun(**args)
    assert py == cli
    from datetime import datetime, timedelta, timezone

    t = datetime(2024, 6, 21, 15, 30, tzinfo=timezone(timedelta(hours=2)))
    assert heliar.sun(args["lat"], args["lon"], t) == cli


def test_scene_sun_matches_the_estimate(scene):
    est = scene.estimator(sequence="hdr")
    e = est.estimate(heliar.read_frame(scene.frame_files("hdr")[0]), scene.frame_times("hdr")[0])
    s = scene.sun(scene.frame_times("hdr")[0])
    assert s["azimuth_deg"] == pytest.approx(e.sun["azimuth_deg"], abs=1e-9)
    assert s["dir_world"] == pytest.approx(e.sun["dir_world"], abs=1e-6)


def test_decomposer_lights_of_a_uniform_sky():
    # A uniform sky of radiance L over the upper hemisphere: total power Σ L·ΔΩ = 2πL and
    # irradiance on an upward surface πL (cosine-weighted integral over the hemisphere).
    L = 0.5
    sky = np.full((90, 360, 3), L, dtype=np.float32)
    d = heliar.vem.Decomposer(lights=300)
    out = d.decompose(sky)
    assert out["status"] == "ok"
    n = out["dir"].shape[0]
    assert n == 300 and out["rgb"].shape == (n, 3) and out["index"].shape == (n,)
    assert np.allclose(np.linalg.norm(out["dir"], axis=1), 1.0, atol=1e-5)
    assert out["power"] == pytest.approx(2 * math.pi * L, rel=1e-3)
    up = np.clip(out["dir"] @ np.array([0.0, 1.0, 0.0], dtype=np.float32), 0, None)
    e_up = (out["rgb"][:, 1] * up).sum()
    assert e_up == pytest.approx(math.pi * L, rel=0.02)  # 300 samples: quadrature within 2%
    again = d.decompose(sky)
    assert np.array_equal(again["index"], out["index"])  # lights keep their identity


def test_decomposer_dark_map_and_bad_settings():
    d = heliar.vem.Decomposer(lights=16)
    assert d.decompose(np.zeros((90, 360, 3), np.float32))["status"] == "dark"
    with pytest.raises(heliar.HeliarError, match="lights"):
        heliar.vem.Decomposer(lights=0)
    with pytest.raises(ValueError, match="sampler 'nope'"):
        heliar.vem.Decomposer(sampler="nope")
    with pytest.raises(TypeError, match="dtype float64"):
        d.decompose(np.zeros((90, 360, 3)))
