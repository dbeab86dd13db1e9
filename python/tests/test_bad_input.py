"""Bad input raises with a message that says what is wrong (and, where the command line has one,
the command line's message)."""

import numpy as np
import pytest

import heliar
from conftest import SCENE


@pytest.fixture(scope="module")
def est():
    return heliar.Scene.load(SCENE).estimator(sequence="hdr")


T0 = "2024-06-21T15:30:00+02:00"


def good():
    return np.full((240, 320, 3), 0.5, dtype=np.float32)


def test_wrong_shape(est):
    with pytest.raises(ValueError, match=r"shape \[240, 320\] is not H×W×3"):
        est.estimate(np.zeros((240, 320), np.float32), T0)
    with pytest.raises(ValueError, match=r"shape \[240, 320, 4\] is not H×W×3"):
        est.estimate(np.zeros((240, 320, 4), np.float32), T0)


def test_wrong_size_names_the_calibration(est):
    with pytest.raises(ValueError, match="image is 640×480 but the camera calibration says 320×240"):
        est.estimate(np.zeros((480, 640, 3), np.float32), T0)


@pytest.mark.parametrize("dtype", [np.float64, np.int32, np.float16, bool])
def test_wrong_dtype(est, dtype):
    with pytest.raises(TypeError, match="is not supported; expected an H×W×3 numpy array of float32"):
        est.estimate(good().astype(dtype), T0)


def test_not_an_array(est):
    with pytest.raises(TypeError, match="expected an H×W×3 numpy array"):
        est.estimate([[0.0, 0.0, 0.0]], T0)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_values_are_named(est, bad):
    f = good()
    f[10, 20, 1] = bad
    f[11, 0, 0] = bad
    with pytest.raises(ValueError, match="2 values are NaN or infinite \\(the first at row 10, column 20, channel 1\\)"):
        est.estimate(f, T0)


def test_bad_times(est):
    from datetime import datetime

    with pytest.raises(ValueError, match="not RFC 3339 with offset"):
        est.estimate(good(), "yesterday")
    with pytest.raises(ValueError, match="not RFC 3339 with offset"):
        est.estimate(good(), datetime(2024, 6, 21, 15, 30))  # naive: no offset
    with pytest.raises(TypeError, match="expected an RFC 3339 string or a datetime"):
        est.estimate(good(), 12.5)


def test_non_contiguous_arrays_are_read_correctly(est):
    f = heliar.read_frame(heliar.Scene.load(SCENE).frame_files("hdr")[0])
    strided = np.asfortranarray(f)
    assert not strided.flags["C_CONTIGUOUS"]
    a = heliar.Scene.load(SCENE).estimator(sequence="hdr").estimate(f, T0, index=0)
    b = heliar.Scene.load(SCENE).estimator(sequence="hdr").estimate(strided, T0, index=0)
    assert a.to_dict()["pd"] == b.to_dict()["pd"]


def test_scene_errors_carry_the_cli_message(run_cli, tmp_path):
    missing = tmp_path / "nowhere"
    cli = run_cli("estimate", missing, check=False)
    assert cli.returncode != 0
    with pytest.raises(heliar.HeliarError) as e:
        heliar.Scene.load(missing)
    assert f"error: {e.value}" == cli.stderr.strip().splitlines()[-1]


def test_unknown_sequence_carries_the_cli_message(run_cli):
    scene = heliar.Scene.load(SCENE)
    with pytest.raises(heliar.HeliarError, match="no sequence named 'night' \\(have: hdr, ldr\\)"):
        scene.estimator(sequence="night")
    cli = run_cli("estimate", SCENE, "--sequence", "night", check=False)
    assert "no sequence named 'night' (have: hdr, ldr)" in cli.stderr


def test_bad_settings():
    scene = heliar.Scene.load(SCENE)
    with pytest.raises(ValueError, match="darkening 'soft'"):
        scene.compositor(darkening="soft")
    with pytest.raises(ValueError, match="samples 3"):
        scene.compositor(samples=3)
    with pytest.raises(ValueError, match="samples 0"):
        scene.estimator(samples=0)
    with pytest.raises(ValueError, match="lat: 91 is not in \\[-90, 90\\]"):
        heliar.sun(91, 0, "2024-06-21T12:00:00Z")
    with pytest.raises(ValueError, match="not a unit vector"):
        heliar.Lighting((0, 2, 0), (1, 1, 1), (1, 1, 1))
    comp_frame = np.zeros((240, 320, 3), np.float32)
    with pytest.raises(TypeError, match="expected an Estimate"):
        scene.compositor(samples=1, transfer_paths=0).composite(comp_frame, {"pd": 1})
