"""Calibration files of the field, written by the programs themselves (OpenCV's FileStorage as
its tutorial program, its calibration.cpp sample and stereo programs write them, after a real
calibrateCamera / stereoCalibrate run on synthetic corners), ROS camera_info as the ROS
camera_calibration package writes it, Kalibr camchains of several cameras: each read for
the K and distortion it holds, every other key left unread; a file lacking what genie-gl needs
refused in one line naming the file and the field."""

import logging

import cv2
import numpy as np
import pytest
import yaml

import genie_gl as gg
from genie_gl.sensors.calibration import read_calibration

SIZE = (640, 480)
K_TRUE = np.array([[610.0, 0, 322.0], [0, 605.0, 241.0], [0, 0, 1]])
D_TRUE = np.array([-0.21, 0.09, 0.001, -0.0015, -0.02])
BOARD = (9, 6)
SQUARE_M = 0.025


def board_points() -> np.ndarray:
    g = np.mgrid[0 : BOARD[0], 0 : BOARD[1]].T.reshape(-1, 2) * SQUARE_M
    return np.c_[g, np.zeros(len(g))].astype(np.float32)


def views(n: int = 12, seed: int = 0) -> list[tuple[np.ndarray, np.ndarray]]:
    """(rvec, tvec) of n board poses in front of a camera, tilted every way."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        r = rng.uniform(-0.5, 0.5, 3)
        t = np.array([rng.uniform(-0.12, 0.02), rng.uniform(-0.1, 0.0), rng.uniform(0.45, 0.7)])
        out.append((r, t))
    return out


def corners(K, D, poses, R=np.eye(3), T=np.zeros(3)) -> list[np.ndarray]:
    """The board's corners as a camera at (R, T) from the first sees them (float32 (N, 1, 2))."""
    obj = board_points().astype(np.float64)
    out = []
    for rvec, tvec in poses:
        Rb = cv2.Rodrigues(rvec)[0]
        r2, _ = cv2.Rodrigues(R @ Rb)
        px, _ = cv2.projectPoints(obj, r2, R @ tvec + T, K, D)
        out.append(px.astype(np.float32))
    return out


@pytest.fixture(scope="module")
def calibrated():
    """A real cv2.calibrateCamera run: (rms, K, D, rvecs, tvecs, image points)."""
    poses = views()
    img = corners(K_TRUE, D_TRUE, poses)
    rms, K, D, rvecs, tvecs = cv2.calibrateCamera(
        [board_points()] * len(img), img, SIZE, None, None
    )
    assert rms < 1e-3 and np.allclose(K, K_TRUE, atol=0.5)  # the run worked
    return rms, K, D, rvecs, tvecs, img


def check(calib, K, D, size=SIZE):
    np.testing.assert_array_equal(calib.K, K)
    np.testing.assert_array_equal(calib.dist, np.asarray(D, np.float64).ravel())
    assert (calib.width, calib.height) == size


def extrinsics(rvecs, tvecs) -> np.ndarray:
    return np.hstack([np.asarray(rvecs).reshape(-1, 3), np.asarray(tvecs).reshape(-1, 3)])


def image_points(img) -> np.ndarray:
    return np.stack([p.reshape(-1, 2) for p in img]).astype(
        np.float32
    )  # (views, corners, 2): CV_32FC2


@pytest.mark.parametrize("ext", [".xml", ".yml"])
def test_the_tutorial_programs_out_camera_data(tmp_path, calibrated, ext):
    """out_camera_data.xml/.yml as OpenCV's camera-calibration tutorial program writes it."""
    rms, K, D, rvecs, tvecs, img = calibrated
    path = tmp_path / f"out_camera_data{ext}"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("calibration_Time", "Sun Nov 29 07:01:26 2026")
    fs.write("nrOfFrames", len(img))
    fs.write("image_Width", SIZE[0])
    fs.write("image_Height", SIZE[1])
    fs.write("board_Width", BOARD[0])
    fs.write("board_Height", BOARD[1])
    fs.write("square_Size", 25.0)
    fs.write("FixAspectRatio", 1.0)
    fs.writeComment("flags:  +fix_aspectRatio +fix_principal_point +zero_tangent_dist")
    fs.write("flagValue", 14)
    fs.write("Camera_Matrix", K)
    fs.write("Distortion_Coefficients", D)
    fs.write("Avg_Reprojection_Error", rms)
    fs.write("Per_View_Reprojection_Errors", np.full((len(img), 1), rms, np.float32))
    fs.writeComment("a set of 6-tuples (rotation vector + translation vector) for each view")
    fs.write("Extrinsic_Parameters", extrinsics(rvecs, tvecs))
    fs.write("Image_points", image_points(img))
    fs.release()
    c = read_calibration(path)
    check(c, K, D)
    assert c.reprojection_error == pytest.approx(rms) and c.model == "pinhole"
    s = gg.load_sensor(path)
    np.testing.assert_array_equal(s.K, K)


@pytest.mark.parametrize("ext", [".xml", ".yml"])
def test_the_newer_tutorial_program_and_its_fisheye_model(tmp_path, calibrated, ext):
    """The tutorial program as OpenCV 4 ships it: lower-case keys, marker_size, fisheye_model 0
    (pinhole) or 1 (then the four coefficients are the fisheye's, read as such)."""
    rms, K, D, rvecs, tvecs, img = calibrated
    for fisheye, dist in ((0, D), (1, np.array([[0.05], [-0.01], [0.002], [-0.0004]]))):
        path = tmp_path / f"out{fisheye}{ext}"
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
        fs.write("calibration_time", "Sun Nov 29 07:01:26 2026")
        fs.write("nr_of_frames", len(img))
        fs.write("image_width", SIZE[0])
        fs.write("image_height", SIZE[1])
        fs.write("board_width", BOARD[0])
        fs.write("board_height", BOARD[1])
        fs.write("square_size", 25.0)
        fs.write("marker_size", 15.0)
        fs.write("flags", 0)
        fs.write("fisheye_model", fisheye)
        fs.write("camera_matrix", K)
        fs.write("distortion_coefficients", dist)
        fs.write("avg_reprojection_error", rms)
        fs.write("per_view_reprojection_errors", np.full((len(img), 1), rms, np.float32))
        fs.write("extrinsic_parameters", extrinsics(rvecs, tvecs))
        fs.write("image_points", image_points(img))
        fs.release()
        c = read_calibration(path)
        check(c, K, dist)
        assert c.model == ("fisheye" if fisheye else "pinhole")


@pytest.mark.parametrize("ext", [".xml", ".yml"])
def test_the_calibration_cpp_sample(tmp_path, calibrated, ext):
    """What samples/cpp/calibration.cpp writes (-a aspect ratio, -o out file, -op -oe)."""
    rms, K, D, rvecs, tvecs, img = calibrated
    path = tmp_path / f"camera{ext}"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("calibration_time", "Sun Nov 29 07:01:26 2026")
    fs.write("nframes", len(img))
    fs.write("image_width", SIZE[0])
    fs.write("image_height", SIZE[1])
    fs.write("board_width", BOARD[0])
    fs.write("board_height", BOARD[1])
    fs.write("square_size", 0.025)
    fs.write("aspectRatio", 1.0)
    fs.writeComment("flags: +fix_aspectRatio")
    fs.write("flags", 2)
    fs.write("camera_matrix", K)
    fs.write("distortion_coefficients", D)
    fs.write("avg_reprojection_error", rms)
    fs.write("per_view_reprojection_errors", np.full((len(img), 1), rms, np.float32))
    fs.writeComment("a set of 6-tuples (rotation vector + translation vector) for each view")
    fs.write("extrinsic_parameters", extrinsics(rvecs, tvecs))
    fs.write("image_points", image_points(img))
    fs.release()
    check(read_calibration(path), K, D)


@pytest.fixture(scope="module")
def stereo():
    """A real cv2.stereoCalibrate run: camera 2 sits 6 cm right of camera 1, turned 2 degrees."""
    K2 = np.array([[598.0, 0, 317.0], [0, 597.0, 244.0], [0, 0, 1]])
    D2 = np.array([-0.18, 0.05, -0.0005, 0.002, 0.0])
    R = cv2.Rodrigues(np.array([0.0, np.radians(2.0), 0.0]))[0]
    T = np.array([-0.06, 0.0, 0.001])
    poses = views(14, seed=1)
    img1 = corners(K_TRUE, D_TRUE, poses)
    img2 = corners(K2, D2, poses, R, T)
    obj = [board_points()] * len(poses)
    _, K1g, D1g, _, _ = cv2.calibrateCamera(obj, img1, SIZE, None, None)
    _, K2g, D2g, _, _ = cv2.calibrateCamera(obj, img2, SIZE, None, None)
    out = cv2.stereoCalibrate(
        obj, img1, img2, K1g, D1g, K2g, D2g, SIZE, flags=cv2.CALIB_USE_INTRINSIC_GUESS
    )
    rms, M1, D1, M2, D2s, Rs, Ts, E, F = out[:9]
    assert rms < 1e-3 and np.allclose(Ts.ravel(), T, atol=1e-4)  # the run worked
    R1, R2, P1, P2, Q, *_ = cv2.stereoRectify(M1, D1, M2, D2s, SIZE, Rs, Ts)
    return {
        "M1": M1,
        "D1": D1,
        "M2": M2,
        "D2": D2s,
        "R": Rs,
        "T": Ts,
        "E": E,
        "F": F,
        "R1": R1,
        "R2": R2,
        "P1": P1,
        "P2": P2,
        "Q": Q,
    }


@pytest.mark.parametrize("ext", [".yml", ".xml"])
def test_a_stereo_calibration_gives_either_camera(tmp_path, stereo, ext):
    """stereoCalibrate's M1 D1 M2 D2 R T E F and stereoRectify's R1 R2 P1 P2 Q in one file, as
    a stereo program writes them (with the image size): camera 0 is M1/D1, camera 1 M2/D2, each
    with R, T to the other."""
    path = tmp_path / f"stereo{ext}"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", SIZE[0])
    fs.write("image_height", SIZE[1])
    for key in ("M1", "D1", "M2", "D2", "R", "T", "E", "F", "R1", "R2", "P1", "P2", "Q"):
        fs.write(key, stereo[key])
    fs.release()
    first = read_calibration(path)
    check(first, stereo["M1"], stereo["D1"])
    np.testing.assert_array_equal(first.T, stereo["T"].ravel())
    second = read_calibration(path, camera=1)
    check(second, stereo["M2"], stereo["D2"])
    assert read_calibration(path, camera="cam1").K[0, 0] == stereo["M2"][0, 0]
    # the way back: camera 2 -> camera 1 undoes camera 1 -> camera 2
    np.testing.assert_allclose(second.R @ stereo["R"], np.eye(3), atol=1e-12)
    np.testing.assert_allclose(second.R @ stereo["T"].ravel() + second.T, 0, atol=1e-12)
    s = gg.Sensor.from_opencv(path, camera=1)
    np.testing.assert_array_equal(s.K, stereo["M2"])
    # a profile picks the camera by its 'camera' field
    prof = tmp_path / "right.yaml"
    prof.write_text(f"calibration: {path.name}\ncamera: 1\n")
    np.testing.assert_array_equal(gg.load_sensor(prof).K, stereo["M2"])


def test_stereo_calibs_intrinsics_file_lacks_the_image_size(tmp_path, stereo):
    """stereo_calib.cpp writes intrinsics.yml with M1 D1 M2 D2 and no image size: refused in
    one line that names the file and the size; the camera asked past the file's is too."""
    path = tmp_path / "intrinsics.yml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for key in ("M1", "D1", "M2", "D2"):
        fs.write(key, stereo[key])
    fs.release()
    with pytest.raises(
        gg.ConfigError, match=r"intrinsics\.yml: missing field image_width/image_height"
    ) as info:
        read_calibration(path)
    assert "\n" not in str(info.value)
    with pytest.raises(gg.ConfigError, match=r"camera 'cam5x': expected"):
        read_calibration(path, camera="cam5x")  # neither index nor name
    with pytest.raises(
        gg.ConfigError, match=r"camera 2: no camera matrix for it \(M3, K3 or cameraMatrix3"
    ):
        read_calibration(path, camera=2)


def ros_mat(a, precision):
    """The ROS camera_calibration package's format_mat (calibrator.py)."""
    return "[%s]" % (
        np.array2string(
            np.asarray(a, float).ravel(), precision=precision, suppress_small=True, separator=", "
        )
        .replace("[", "")
        .replace("]", "")
        .replace("\n", "\n        ")
    )


def ros_camera_info(K, D, model, name="narrow_stereo") -> str:
    """ost.yaml as the ROS camera_calibration package's ``yaml()`` writes it (ROS is not
    installed here: its writer, line for line)."""
    P = np.c_[K, np.zeros(3)]
    return "\n".join(
        [
            f"image_width: {SIZE[0]}",
            f"image_height: {SIZE[1]}",
            f"camera_name: {name}",
            "camera_matrix:",
            "  rows: 3",
            "  cols: 3",
            "  data: " + ros_mat(K, 5),
            f"distortion_model: {model}",
            "distortion_coefficients:",
            "  rows: 1",
            f"  cols: {len(D)}",
            "  data: [%s]" % ", ".join("%8f" % x for x in D),
            "rectification_matrix:",
            "  rows: 3",
            "  cols: 3",
            "  data: " + ros_mat(np.eye(3), 8),
            "projection_matrix:",
            "  rows: 3",
            "  cols: 4",
            "  data: " + ros_mat(P, 5),
            "",
        ]
    )


@pytest.mark.parametrize(
    "model, D",
    [
        ("plumb_bob", [-0.21, 0.09, 0.001, -0.0015, -0.02]),
        ("rational_polynomial", [-0.2, 0.08, 0.001, -0.001, 0.01, 0.1, 0.02, 0.003]),
        ("equidistant", [0.05, -0.01, 0.002, -0.0004]),
    ],
)
def test_ros_camera_info_as_camera_calibration_writes_it(tmp_path, model, D):
    K = np.array([[610.12345, 0, 322.5], [0, 605.25, 241.75], [0, 0, 1]])
    path = tmp_path / "ost.yaml"
    path.write_text(ros_camera_info(K, D, model))
    c = read_calibration(path)
    check(c, K, D)  # what the text holds: 5 decimals of K, 6 of D ("%8f")
    assert c.model == ("fisheye" if model == "equidistant" else "pinhole")
    s = gg.load_sensor(path)  # a bare camera_info is a sensor of its own
    np.testing.assert_array_equal(s.K, K)


KALIBR = {
    "cam0": {
        "camera_model": "pinhole",
        "intrinsics": [458.654, 457.296, 367.215, 248.375],
        "distortion_model": "radtan",
        "distortion_coeffs": [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05],
        "resolution": [752, 480],
        "rostopic": "/cam0/image_raw",
        "cam_overlaps": [1, 2],
        "T_cam_imu": np.eye(4).tolist(),
        "timeshift_cam_imu": 0.001,
    },
    "cam1": {
        "T_cn_cnm1": [
            [0.99999, 0.0023, 0.0003, -0.11007],
            [-0.0023, 0.99996, 0.0089, 0.00039],
            [-0.0003, -0.0089, 0.99996, -0.00085],
            [0, 0, 0, 1.0],
        ],
        "camera_model": "pinhole",
        "intrinsics": [457.587, 456.134, 379.999, 255.238],
        "distortion_model": "equidistant",
        "distortion_coeffs": [-0.0128, 0.0034, -0.0021, 0.0004],
        "resolution": [752, 480],
        "rostopic": "/cam1/image_raw",
        "cam_overlaps": [0],
    },
    "cam2": {
        "T_cn_cnm1": np.eye(4).tolist(),
        "camera_model": "pinhole",
        "intrinsics": [300.0, 301.0, 160.0, 120.0],
        "distortion_model": "none",
        "distortion_coeffs": [],
        "resolution": [320, 240],
        "rostopic": "/cam2/image_raw",
    },
}


def kalibr_k(fu, fv, pu, pv):
    return np.array([[fu, 0, pu], [0, fv, pv], [0, 0, 1.0]])


def test_a_kalibr_camchain_of_three_cameras(tmp_path):
    path = tmp_path / "camchain-imucam.yaml"
    path.write_text(yaml.safe_dump(KALIBR, default_flow_style=None))
    for name, model in (("cam0", "pinhole"), ("cam1", "fisheye"), ("cam2", "pinhole")):
        c = read_calibration(path, camera=name)
        cam = KALIBR[name]
        check(c, kalibr_k(*cam["intrinsics"]), cam["distortion_coeffs"], tuple(cam["resolution"]))
        assert c.model == model
    assert read_calibration(path).K[0, 0] == 458.654  # cam0 unless told
    assert read_calibration(path, camera=1).model == "fisheye"
    # cam0's baseline is cam1's T_cn_cnm1; cam1's goes on to cam2 (identity: no baseline)
    assert read_calibration(path).baseline_m == pytest.approx(
        np.linalg.norm([-0.11007, 0.00039, -0.00085])
    )
    assert read_calibration(path, camera="cam1").baseline_m == 0
    with pytest.raises(
        gg.ConfigError,
        match=r"camera 'cam3': not in this camchain; did you mean 'cam2'\?.*"
        r"its cameras: cam0, cam1, cam2",
    ):
        read_calibration(path, camera="cam3")
    prof = tmp_path / "p.yaml"
    prof.write_text(f"calibration: {path.name}\ncamera: cam2\n")
    assert gg.load_sensor(prof).width == 320


def test_vendor_numbers_and_unread_keys_are_listed_at_debug(tmp_path, caplog):
    """A vendor's JSON of fx, fy, ppx, ppy and k1..k3 reads as the K and D they spell; the
    keys genie-gl does not need are listed once, at debug level."""
    path = tmp_path / "vendor.json"
    path.write_text(
        '{"serial": "123", "width": 1280, "height": 720, "fx": 640.5, "fy": 641.0, "ppx": 637.2, '
        '"ppy": 362.9, "k1": -0.05, "k2": 0.06, "p1": 0.0002, "p2": -0.0001, "k3": -0.02, '
        '"firmware": "5.13"}'
    )
    with caplog.at_level(logging.DEBUG, logger="genie_gl.sensors.calibration"):
        c = read_calibration(path)
    check(
        c, kalibr_k(640.5, 641.0, 637.2, 362.9), [-0.05, 0.06, 0.0002, -0.0001, -0.02], (1280, 720)
    )
    listed = [r.getMessage() for r in caplog.records if "not read" in r.getMessage()]
    assert len(listed) == 1 and "serial, firmware" in listed[0]


def write_cv(path, **fields):
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for k, v in fields.items():
        fs.write(k, v)
    fs.release()
    return path


@pytest.mark.parametrize(
    "fields, needle",
    [
        (
            {"image_width": 640, "image_height": 480, "distortion_coefficients": np.zeros((5, 1))},
            r"missing field camera_matrix \(K\)",
        ),
        (
            {"image_width": 640, "image_height": 480, "Camera_Matrix": np.eye(3)[:2]},
            r"Camera_Matrix: expected a 3x3 matrix, got shape \(2, 3\)",
        ),
        (
            {
                "image_width": 640,
                "image_height": 480,
                "camera_matrix": np.array([[np.nan, 0, 1], [0, 1, 1], [0, 0, 1]]),
            },
            "camera_matrix: contains NaN or Inf",
        ),
        (
            {"image_width": 640, "image_height": 480, "camera_matrix": np.diag([-600.0, 600, 1])},
            "camera_matrix: fx and fy must be > 0, got -600 and 600",
        ),
        (
            {"image_width": 0, "image_height": 480, "camera_matrix": K_TRUE},
            r"image_width: expected a whole number in 1",
        ),
        ({"image_Height": 480, "camera_matrix": K_TRUE}, "missing field image_width/image_height"),
        (
            {"image_width": 640, "image_height": 480, "camera_matirx": K_TRUE},
            r"missing field camera_matrix.*the file's 'camera_matirx' is not read: did you mean "
            r"'cameramatrix'",
        ),
        (
            {
                "image_width": 640,
                "image_height": 480,
                "camera_matrix": K_TRUE,
                "distortion_coefficients": np.zeros((3, 1)),
            },
            "distortion_coefficients: expected 4, 5, 8, 12 or 14 coefficients, got 3",
        ),
    ],
)
def test_what_is_needed_and_missing_or_malformed_is_one_line(tmp_path, fields, needle):
    path = write_cv(tmp_path / "c.yml", **fields)
    with pytest.raises(gg.ConfigError, match=r"c\.yml: " + needle) as info:
        gg.load_sensor(path)
    assert "\n" not in str(info.value)


def test_a_misspelt_key_of_our_own_profile_is_still_refused(tmp_path):
    write_cv(tmp_path / "c.yml", image_width=64, image_height=48, camera_matrix=K_TRUE)
    (tmp_path / "p.yaml").write_text("calibration: c.yml\ncamrea: 1\n")
    with pytest.raises(
        gg.ConfigError,
        match=r"p\.yaml: camrea: not a field of a sensor profile; did you mean 'camera'",
    ):
        gg.load_sensor(tmp_path / "p.yaml")
