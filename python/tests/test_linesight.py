"""The Python module against the library's contract and the CLI's outputs."""
import ast
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import linesight


def test_isgm_on_aloe_equals_the_cli_bit_for_bit(aloe, cli, tmp_path):
    left_path, right_path, left, right = aloe
    out = tmp_path / "aloe.pfm"
    subprocess.run([cli, "disparity", "--method", "isgm", "--num-disp", "96", "--left",
                    str(left_path), "--right", str(right_path), "--out", str(out)],
                   check=True, capture_output=True, timeout=300)
    from_cli = linesight.read_pfm(out)
    from_python = linesight.compute_disparity(left, right, method="isgm", num_disparities=96)
    assert from_python.dtype == np.float32 and from_python.shape == left.shape[:2]
    assert np.isfinite(from_python).mean() > 0.9
    # Bit for bit, +inf (no estimate) included.
    assert from_python.tobytes() == from_cli.tobytes()


def test_every_matcher_runs_and_reports_its_settings(aloe):
    _, _, left, right = aloe
    small = (slice(300, 460), slice(400, 640))
    for method in linesight.matchers():
        if method == "gc":  # graph cuts take minutes single-threaded; its C++ tests cover it
            continue
        matcher = linesight.Matcher(method, num_disparities=64, threads=1)
        disparity, checked = matcher.compute(left[small], right[small])
        assert disparity.shape == (160, 240) and disparity.dtype == np.float32
        finite = disparity[np.isfinite(disparity)]
        assert finite.size > 0 and finite.min() >= 0 and finite.max() <= 63
        assert checked.shape == disparity.shape
        assert matcher.name == method
        assert isinstance(matcher.settings, dict)


def test_matcher_params_are_checked_with_the_library_messages(aloe):
    _, _, left, right = aloe
    with pytest.raises(linesight.UsageError, match="unknown method 'nope'"):
        linesight.Matcher("nope")
    with pytest.raises(linesight.UsageError, match="no_such_key"):
        linesight.Matcher("sgm", params={"no_such_key": 1})
    with pytest.raises(linesight.OptionError, match="num_disparities = 0"):
        linesight.Matcher("sgm", num_disparities=0)
    assert issubclass(linesight.OptionError, linesight.InputError)
    assert issubclass(linesight.InputError, ValueError)
    with pytest.raises(linesight.InputError, match="uint8"):
        linesight.compute_disparity(left.astype(np.float32), right)
    with pytest.raises(linesight.InputError, match="same size"):
        linesight.compute_disparity(left, right[:-1])
    with pytest.raises(linesight.InputError, match="/nonexistent.png"):
        linesight.read_image("/nonexistent.png")
    params = linesight.Matcher("sgm", params={"paths": 4}).settings
    assert params["paths"] == 4


def test_ranging_the_rendered_scene_finds_its_obstacles(scene):
    calibration = scene["calibration"]
    assert calibration.image_size == (752, 480)
    pipeline = linesight.RangingPipeline(calibration, method="isgm", threads=1)
    assert pipeline.settings["method"] == "isgm"
    damper = next(o for o in scene["obstacles"] if o["type"] == "damper")
    x, y, w, h = damper["box"]
    result = pipeline.range(scene["left"], scene["right"], rois=[(x - 10, y - 10, w + 20, h + 20)],
                            auto=True)
    assert result["disparity"].shape == (480, 752)
    ranged = result["obstacles"][0]
    assert ranged["source"] == "roi" and ranged["status"] == "ok"
    assert ranged["distance_m"] == pytest.approx(damper["distance_m"], rel=0.02)
    assert any(o["source"] == "auto" for o in result["obstacles"][1:])
    with pytest.raises(linesight.UsageError, match="unknown key"):
        linesight.RangingPipeline(calibration, settings={"no_such_setting": 1})
    assert "line" not in result
    with pytest.raises(linesight.InputError):
        pipeline.range(scene["left"], scene["right"], rois=[(700, 400, 200, 200)])


def test_the_line_finder_types_the_obstacles_on_the_conductor(scene):
    pipeline = linesight.RangingPipeline(scene["calibration"], method="isgm", threads=1, line=True)
    line = pipeline.range(scene["left"], scene["right"])["line"]
    assert line["conductor"]["status"] == "ok"
    found = line["obstacles"]
    assert [o["arc_m"] for o in found] == sorted(o["arc_m"] for o in found)  # nearest first
    damper = next(o for o in scene["obstacles"] if o["type"] == "damper")
    nearest = found[0]
    assert nearest["type"] == "damper"
    assert nearest["distance_m"] == pytest.approx(damper["distance_m"], rel=0.03)


def test_rectification_point_cloud_and_depth_agree_with_the_truth(scene, tmp_path):
    calibration = scene["calibration"]
    rectifier = linesight.Rectifier(calibration)
    left, right = rectifier.rectify(scene["left"], scene["right"])
    assert left.shape == scene["left"].shape and left.dtype == np.uint8
    rectified = rectifier.calibration
    truth = scene["disparity"]
    depth = linesight.depth_from_disparity(truth, rectified)
    valid = np.isfinite(truth) & (truth > 0)
    np.testing.assert_allclose(depth[valid], scene["depth"][valid], rtol=1e-4)
    points, colors = linesight.point_cloud(truth, rectified, color=left, max_depth_m=5, stride=2)
    assert points.shape[1] == 3 and colors.shape == points.shape and colors.dtype == np.uint8
    assert 0 < points[:, 2].max() <= 5
    path = tmp_path / "stereo.yml"
    calibration.write(path)
    again = linesight.StereoCalibration.read(path)
    np.testing.assert_allclose(again.as_dict()["P1"], calibration.as_dict()["P1"])
    linesight.write_pfm(tmp_path / "d.pfm", truth)
    assert linesight.read_pfm(tmp_path / "d.pfm").tobytes() == truth.tobytes()


def test_calibration_from_images_finds_the_boards_of_opencvs_sample_pairs(aloe):
    data = aloe[0].parent
    lefts = [linesight.read_image(data / f"left0{i}.jpg") for i in range(1, 7)]
    rights = [linesight.read_image(data / f"right0{i}.jpg") for i in range(1, 7)]
    found = linesight.detect_pattern(lefts[0], "chessboard:9x6:0.025")
    assert found["found"] and found["pixels"].shape == (54, 2)
    calibration, report = linesight.calibrate_stereo(lefts, rights, "chessboard:9x6:0.025")
    assert calibration.image_size == (640, 480)
    # OpenCV's stereo_calib sample: a baseline of about 3.3 squares.
    assert 0.07 < calibration.baseline_m < 0.095
    assert report["rms_px"]["stereo"] < 1.0


def test_calibration_from_corners_recovers_the_rendered_rig():
    # Corners of a 9x6 board seen by a known pinhole pair at a few poses, projected exactly.
    focal, cx, cy, baseline = 700.0, 320.0, 240.0, 0.12
    board = np.array([[c * 0.03, r * 0.03, 0.0] for r in range(6) for c in range(9)])
    rng = np.random.default_rng(7)
    left_views, right_views = [], []
    for _ in range(8):
        angles = rng.uniform(-0.35, 0.35, 3)
        rotation = _rotation(angles)
        t = np.array([-0.12, -0.075, 0.0]) + rng.uniform([-0.05, -0.05, 0.6], [0.05, 0.05, 0.9])
        camera = board @ rotation.T + t
        left_views.append(_project(camera, focal, cx, cy))
        right_views.append(_project(camera - [baseline, 0, 0], focal, cx, cy))
    calibration, report = linesight.calibrate_stereo_from_corners(
        left_views, right_views, (640, 480), "chessboard:9x6:0.03")
    assert calibration.baseline_m == pytest.approx(baseline, rel=1e-3)
    assert calibration.as_dict()["M1"][0, 0] == pytest.approx(focal, rel=1e-3)
    assert isinstance(report, dict)
    with pytest.raises(linesight.InputError, match="corners"):
        linesight.calibrate_stereo_from_corners(
            [left_views[0][:10]], [right_views[0]], (640, 480), "chessboard:9x6:0.03")


def test_the_stub_lists_every_public_name():
    stub = pathlib.Path(linesight.__file__).with_name("_core.pyi").read_text()
    tree = ast.parse(stub)
    stubbed = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    assert set(linesight.__all__) == stubbed
    for name in linesight.__all__:
        assert getattr(linesight, name).__doc__ or name.endswith("Error"), name


def _rotation(angles):
    ax, ay, az = angles
    rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
    ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
    rz = np.array([[np.cos(az), -np.sin(az), 0], [np.sin(az), np.cos(az), 0], [0, 0, 1]])
    return rz @ ry @ rx


def _project(points, focal, cx, cy):
    return np.stack([focal * points[:, 0] / points[:, 2] + cx,
                     focal * points[:, 1] / points[:, 2] + cy], axis=1)


def test_the_readme_example_runs():
    example = pathlib.Path(__file__).parents[1] / "examples" / "range_scene.py"
    done = subprocess.run([sys.executable, str(example)], capture_output=True, text=True,
                          timeout=300, check=True)
    lines = done.stdout.splitlines()
    assert lines[0].split()[0] == "type" and len(lines) >= 3, done.stdout
