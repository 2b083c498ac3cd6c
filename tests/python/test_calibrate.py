"""gst-landmark calibrate: the seed's relations, chessboard intrinsics and
the floor mounting, on chessboards rendered here with known cameras."""

import math

import cv2
import numpy as np
import pytest

from gstlandmark.commands import calibrate
from gstlandmark.commands.cli import main
from gstlandmark.synth.camera import Camera, Pose

WIDTH, HEIGHT = 640, 480
PATTERN = (9, 6)
SQUARE = 0.025
SUPER = 4


# ---------------------------------------------------------------------------
# Rendering a chessboard (independent of the code under test)


def _square_corners(pattern, square):
    """(rows + 1, cols + 1) squares of the board whose inner corners are
    board_points(); each as 4 board-frame corners (z = 0)."""
    cols, rows = pattern
    quads, black = [], []
    for j in range(-1, rows):
        for i in range(-1, cols):
            x0, y0 = i * square, j * square
            quads.append([(x0, y0), (x0 + square, y0),
                          (x0 + square, y0 + square), (x0, y0 + square)])
            black.append((i + j) % 2 == 0)
    return np.array(quads, dtype=np.float64), black


def render_board(to_world, rvec, tvec, matrix, size=(WIDTH, HEIGHT),
                 pattern=PATTERN, square=SQUARE, background=110):
    """Greyscale image of the chessboard: ``to_world`` maps board-frame
    points (N, 3) to the points projected with ``rvec, tvec, matrix``.
    Drawn at SUPER times the resolution and averaged down."""
    width, height = size
    big = np.array(matrix, dtype=np.float64) * SUPER
    big[2, 2] = 1.0
    # Pixel centres at integers in both images: u_big = s u + (s - 1)/2.
    big[0, 2] += (SUPER - 1) / 2.0
    big[1, 2] += (SUPER - 1) / 2.0
    image = np.full((height * SUPER, width * SUPER), background, np.uint8)

    def draw(quad, value):
        pts = np.zeros((len(quad), 3))
        pts[:, :2] = quad
        uv, _ = cv2.projectPoints(to_world(pts), rvec, tvec, big, None)
        fixed = np.round(uv.reshape(-1, 2) * 16).astype(np.int32)
        cv2.fillConvexPoly(image, fixed, value, lineType=cv2.LINE_8,
                           shift=4)

    cols, rows = pattern
    margin = square * 0.8           # white quiet zone around the squares
    draw(np.array([(-square - margin, -square - margin),
                   (cols * square + margin, -square - margin),
                   (cols * square + margin, rows * square + margin),
                   (-square - margin, rows * square + margin)]), 235)
    quads, black = _square_corners(pattern, square)
    for quad, is_black in zip(quads, black):
        if is_black:
            draw(quad, 25)
    return cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA)


def _rotation(rx, ry, rz):
    rvec_x, _ = cv2.Rodrigues(np.array([math.radians(rx), 0.0, 0.0]))
    rvec_y, _ = cv2.Rodrigues(np.array([0.0, math.radians(ry), 0.0]))
    rvec_z, _ = cv2.Rodrigues(np.array([0.0, 0.0, math.radians(rz)]))
    return rvec_z @ rvec_y @ rvec_x


TRUE_K = np.array([[612.0, 0.0, 322.7], [0.0, 608.5, 236.1],
                   [0.0, 0.0, 1.0]])

# Board orientations (degrees about x, y, z) and centre offsets (m).
VIEWS = [(0, 0, 0, 0.00, 0.00, 0.45), (25, 0, 5, 0.02, 0.01, 0.45),
         (-25, 5, -5, -0.02, 0.00, 0.48), (0, 30, 10, 0.00, 0.02, 0.47),
         (5, -30, -10, 0.01, -0.02, 0.46), (20, 20, 30, 0.0, 0.0, 0.50),
         (-20, -20, -25, 0.0, 0.0, 0.50), (15, -15, 90, 0.0, 0.0, 0.40)]


def _identity(points):
    return points


def render_views(tmp_path, views=VIEWS, matrix=TRUE_K):
    """Chessboard images seen under ``views``; returns their paths."""
    cols, rows = PATTERN
    centre = np.array([(cols - 1) * SQUARE / 2, (rows - 1) * SQUARE / 2,
                       0.0])
    paths = []
    for n, (rx, ry, rz, dx, dy, dist) in enumerate(views):
        rot = _rotation(rx, ry, rz)
        rvec, _ = cv2.Rodrigues(rot)
        tvec = np.array([dx, dy, dist]) - rot @ centre
        image = render_board(_identity, rvec, tvec, matrix)
        path = tmp_path / f"board{n:02d}.png"
        cv2.imwrite(str(path), image)
        paths.append(str(path))
    return paths


# ---------------------------------------------------------------------------
# The seed's relations


def test_seed_relations_hand_computed():
    # h = 1, b = 1: gamma = 45 deg; b + d = sqrt(3): gamma + alpha = 60
    # deg, so alpha = 15 deg and theta = 30 deg; w = b + d: beta = 45 deg.
    geo = calibrate.seed_geometry(1.0, 1.0, math.sqrt(3.0) - 1.0,
                                  math.sqrt(3.0))
    assert math.degrees(geo.gamma) == pytest.approx(45.0)
    assert math.degrees(geo.alpha) == pytest.approx(15.0)
    assert geo.tilt_deg == pytest.approx(30.0)
    assert geo.vfov_deg == pytest.approx(30.0)
    assert geo.hfov_deg == pytest.approx(90.0)
    # h = 0.3, b = 0.2, d = 0.6, w = 0.4, by hand:
    # gamma = atan(2/3) = 33.6901 deg, gamma + alpha = atan(8/3) =
    # 69.4440 deg, tilt = atan(3/8) = 20.5560 deg, beta = atan(1/2).
    geo = calibrate.seed_geometry(0.3, 0.2, 0.6, 0.4)
    assert math.degrees(geo.gamma) == pytest.approx(33.690068, abs=1e-5)
    assert geo.vfov_deg == pytest.approx(2 * (69.443955 - 33.690068),
                                         abs=1e-5)
    assert geo.tilt_deg == pytest.approx(20.556045, abs=1e-5)
    assert geo.hfov_deg == pytest.approx(53.130102, abs=1e-5)
    assert math.degrees(geo.alpha + geo.gamma + geo.theta) == \
        pytest.approx(90.0)


@pytest.mark.parametrize("h, b, d, w", [(0.3, 0.2, 0.6, 0.4),
                                        (0.25, 0.15, 1.2, 0.5),
                                        (1.2, 0.8, 2.5, 1.5)])
def test_seed_round_trip(h, b, d, w):
    """Eqs (3.5)-(3.6) with the derived angles give back b, b + d and w."""
    geo = calibrate.seed_geometry(h, b, d, w)
    m, n = 641, 481                 # odd: a centre row and column exist
    _, y_bottom = geo.floor_point(320, n - 1, m, n)
    _, y_centre = geo.floor_point(320, (n - 1) / 2, m, n)
    x_edge, _ = geo.floor_point(m - 1, (n - 1) / 2, m, n)
    x_mid, _ = geo.floor_point((m - 1) / 2, (n - 1) / 2, m, n)
    assert y_bottom == pytest.approx(b)
    assert y_centre == pytest.approx(b + d)
    assert x_edge == pytest.approx(w)
    assert x_mid == pytest.approx(0.0, abs=1e-12)
    # Rebuild from the derived tilt and fields of view alone.
    theta = math.radians(geo.tilt_deg)
    alpha = math.radians(geo.vfov_deg) / 2
    beta = math.radians(geo.hfov_deg) / 2
    far = h / math.tan(theta)
    assert h * math.tan(math.pi / 2 - theta - alpha) == pytest.approx(b)
    assert far - b == pytest.approx(d)
    assert far * math.tan(beta) == pytest.approx(w)


def test_seed_horizon_row():
    geo = calibrate.seed_geometry(0.3, 0.2, 0.6, 0.4)
    rows = 480
    horizon = geo.horizon_row(rows)
    top = 33.690068 + 2 * (69.443955 - 33.690068)       # > 90 deg
    assert horizon == pytest.approx(
        (rows - 1) * (top - 90.0) / (top - 33.690068), abs=1e-3)
    _, y = geo.floor_point(0, math.floor(horizon), 640, rows)
    assert math.isnan(y)
    _, y = geo.floor_point(0, math.floor(horizon) + 1, 640, rows)
    assert y > 0
    assert calibrate.seed_geometry(1.0, 1.0, 0.5, 1.0).horizon_row(
        rows) is None


@pytest.mark.parametrize("args", [(0.0, 0.2, 0.6, 0.4),
                                  (0.3, -0.2, 0.6, 0.4),
                                  (0.3, 0.0, 0.6, 0.4),
                                  (0.3, 0.2, 0.0, 0.4),
                                  (0.3, 0.2, 0.6, -1.0),
                                  (float("nan"), 0.2, 0.6, 0.4),
                                  (0.3, 0.2, float("inf"), 0.4)])
def test_seed_impossible_geometry(args):
    with pytest.raises(calibrate.CalibrationError, match="positive"):
        calibrate.seed_geometry(*args)


def test_seed_cli(tmp_path, capsys):
    out = tmp_path / "seed.yml"
    status = main(["calibrate", "seed", "--height", "1", "--blind", "1",
                   "--depth", repr(math.sqrt(3.0) - 1.0), "--half-width",
                   repr(math.sqrt(3.0)), "--size", "640x480", "-o",
                   str(out)])
    assert status == 0
    text = capsys.readouterr().out
    assert "30.000" in text and "90.000" in text
    assert out.read_text().startswith("%YAML:1.0")
    fs = cv2.FileStorage(str(out), cv2.FILE_STORAGE_READ)
    assert fs.getNode("model").string() == "angle-linear"
    assert fs.getNode("image_width").real() == 640
    assert fs.getNode("image_height").real() == 480
    assert fs.getNode("camera_height").real() == pytest.approx(1.0)
    assert fs.getNode("blind_distance").real() == pytest.approx(1.0)
    assert fs.getNode("view_depth").real() == pytest.approx(
        math.sqrt(3.0) - 1.0)
    assert fs.getNode("half_width").real() == pytest.approx(math.sqrt(3.0))
    assert fs.getNode("tilt_deg").real() == pytest.approx(30.0)
    assert fs.getNode("vfov_deg").real() == pytest.approx(30.0)
    assert fs.getNode("hfov_deg").real() == pytest.approx(90.0)
    fs.release()


def test_seed_cli_errors(tmp_path, capsys):
    out = tmp_path / "seed.yml"
    status = main(["calibrate", "seed", "--height", "0.3", "--blind",
                   "0.2", "--depth", "-1", "--half-width", "0.4", "-o",
                   str(out)])
    assert status == 1
    err = capsys.readouterr().err
    assert "gst-landmark: error: view depth d (--depth)" in err
    assert not out.exists()
    status = main(["calibrate", "seed", "--height", "0.3", "--blind",
                   "0.2", "--depth", "0.6", "--half-width", "0.4",
                   "--size", "640", "-o", str(out)])
    assert status == 2
    status = main(["calibrate", "seed", "--height", "0.3", "--blind",
                   "0.2", "--depth", "0.6", "--half-width", "0.4",
                   "-o", str(tmp_path / "no" / "dir.yml")])
    assert status == 1
    assert "cannot write" in capsys.readouterr().err


# ---------------------------------------------------------------------------
# Intrinsics from chessboard images


@pytest.fixture(scope="module")
def board_images(tmp_path_factory):
    return render_views(tmp_path_factory.mktemp("boards"))


def test_render_matches_projection(board_images):
    """The rendered corners are where projectPoints puts them (checks
    the test renderer itself, to a fraction of a pixel)."""
    cols, rows = PATTERN
    centre = np.array([(cols - 1) * SQUARE / 2, (rows - 1) * SQUARE / 2,
                       0.0])
    rx, ry, rz, dx, dy, dist = VIEWS[1]
    rot = _rotation(rx, ry, rz)
    rvec, _ = cv2.Rodrigues(rot)
    tvec = np.array([dx, dy, dist]) - rot @ centre
    truth, _ = cv2.projectPoints(calibrate.board_points(PATTERN, SQUARE),
                                 rvec, tvec, TRUE_K, None)
    image = cv2.imread(board_images[1], cv2.IMREAD_GRAYSCALE)
    found = calibrate.find_corners(image, PATTERN).reshape(-1, 2)
    truth = truth.reshape(-1, 2)
    if np.linalg.norm(found[0] - truth[0]) > 1.0:
        found = found[::-1]             # detector started at the far end
    assert np.max(np.linalg.norm(found - truth, axis=1)) < 0.15


def test_chessboard_recovers_intrinsics(board_images, tmp_path, capsys):
    out = tmp_path / "camera.yml"
    status = main(["calibrate", "chessboard", *board_images, "--pattern",
                   "9x6", "--square", str(SQUARE), "-o", str(out)])
    assert status == 0
    text = capsys.readouterr().out
    assert "RMS reprojection error" in text
    assert out.read_text().startswith("%YAML:1.0")
    fs = cv2.FileStorage(str(out), cv2.FILE_STORAGE_READ)
    assert set(fs.root().keys()) >= {
        "camera_matrix", "distortion_coefficients", "image_width",
        "image_height", "avg_reprojection_error"}
    matrix = fs.getNode("camera_matrix").mat()
    dist = fs.getNode("distortion_coefficients").mat()
    assert fs.getNode("image_width").isInt()
    assert int(fs.getNode("image_width").real()) == WIDTH
    assert int(fs.getNode("image_height").real()) == HEIGHT
    rms = fs.getNode("avg_reprojection_error").real()
    fs.release()
    assert matrix.shape == (3, 3) and dist.shape == (1, 5)
    assert matrix[2, 2] == 1.0 and matrix[0, 1] == 0.0
    for (r, c) in [(0, 0), (1, 1), (0, 2), (1, 2)]:
        assert matrix[r, c] == pytest.approx(TRUE_K[r, c], rel=0.01)
    assert rms < 0.2
    # The rendered lens has no distortion: the fitted one is small where
    # the boards were (within about 250 px of the centre).
    norm = 250.0 / TRUE_K[0, 0]
    radial = (dist[0, 0] * norm ** 2 + dist[0, 1] * norm ** 4
              + dist[0, 4] * norm ** 6)
    assert abs(radial) < 0.01
    # And it reads back as a camera file.
    camera = calibrate.read_camera_file(str(out))
    assert camera["image_width"] == WIDTH
    np.testing.assert_allclose(camera["camera_matrix"], matrix)


def test_chessboard_pattern_not_found(board_images, tmp_path, capsys):
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((HEIGHT, WIDTH), 128, np.uint8))
    paths = board_images[:2] + [str(blank)] + board_images[2:4]
    out = tmp_path / "camera.yml"
    status = main(["calibrate", "chessboard", *paths, "--pattern", "9x6",
                   "--square", "0.025", "-o", str(out)])
    assert status == 1
    err = capsys.readouterr().err
    assert f"pattern 9x6 not found in image 3 ({blank})" in err
    assert not out.exists()
    # With --skip-missing the other four are enough.
    status = main(["calibrate", "chessboard", *paths, "--pattern", "9x6",
                   "--square", "0.025", "--skip-missing", "-o", str(out)])
    assert status == 0
    captured = capsys.readouterr()
    assert "image 3" in captured.err and "left out" in captured.err
    assert "4 used, 1 left out" in captured.out
    # A wrong pattern is found nowhere.
    status = main(["calibrate", "chessboard", *board_images[:3],
                   "--pattern", "7x7", "--square", "0.025", "-o",
                   str(out)])
    assert status == 1
    assert "pattern 7x7 not found in image 1" in capsys.readouterr().err


def test_chessboard_too_few_images(board_images, tmp_path, capsys):
    out = tmp_path / "camera.yml"
    status = main(["calibrate", "chessboard", *board_images[:2],
                   "--pattern", "9x6", "--square", "0.025", "-o",
                   str(out)])
    assert status == 1
    assert "too few images: 2 usable, need at least 3" in \
        capsys.readouterr().err
    assert not out.exists()
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.zeros((HEIGHT, WIDTH), np.uint8))
    status = main(["calibrate", "chessboard", board_images[0],
                   str(blank), board_images[1], "--skip-missing",
                   "--pattern", "9x6", "--square", "0.025", "-o",
                   str(out)])
    assert status == 1
    assert "too few images: 2 usable, need at least 3" in \
        capsys.readouterr().err


def test_chessboard_bad_input(board_images, tmp_path, capsys):
    out = str(tmp_path / "camera.yml")
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.zeros((240, 320), np.uint8))
    status = main(["calibrate", "chessboard", board_images[0],
                   str(small), "--pattern", "9x6", "--square", "0.025",
                   "-o", out])
    assert status == 1
    assert "image 2" in capsys.readouterr().err
    missing = str(tmp_path / "nope.png")
    status = main(["calibrate", "chessboard", missing, "--pattern", "9x6",
                   "--square", "0.025", "-o", out])
    assert status == 1
    assert f"image 1 ({missing}): no such file" in capsys.readouterr().err
    for bad in (["--pattern", "9"], ["--pattern", "1x6"],
                ["--square", "0"], ["--square", "-0.02"]):
        argv = ["calibrate", "chessboard", board_images[0], "--pattern",
                "9x6", "--square", "0.025", "-o", out]
        argv[argv.index(bad[0]) + 1] = bad[1]
        assert main(argv) == 2


# ---------------------------------------------------------------------------
# Mounting from a chessboard on the floor


def _floor_image(camera, origin, yaw_deg, path):
    """A chessboard lying on the floor: its inner-corner grid centred at
    robot-frame ``origin``, turned ``yaw_deg`` about the vertical."""
    cols, rows = PATTERN
    middle = np.array([(cols - 1) * SQUARE / 2, (rows - 1) * SQUARE / 2])
    yaw = math.radians(yaw_deg)
    turn = np.array([[math.cos(yaw), -math.sin(yaw)],
                     [math.sin(yaw), math.cos(yaw)]])

    def to_world(points):
        flat = (points[:, :2] - middle) @ turn.T + np.asarray(origin)
        return np.column_stack([flat, np.zeros(len(points))])

    pose = Pose(0.0, 0.0, 0.0)      # robot frame = world frame
    rvec, tvec = camera.rvec_tvec(pose)
    image = render_board(to_world, rvec, tvec, camera.matrix,
                         size=(camera.width, camera.height))
    cv2.imwrite(str(path), image)
    return str(path)


def _write_intrinsics(camera, path):
    calibrate.write_camera_file(str(path), {
        "image_width": camera.width, "image_height": camera.height,
        "camera_matrix": camera.matrix,
        "distortion_coefficients": np.zeros((1, 5))})
    return str(path)


@pytest.mark.parametrize("height, tilt, roll, origin, yaw", [
    (0.30, 25.0, 0.0, (0.55, 0.0), 0.0),
    (0.30, 25.0, 3.0, (0.55, 0.05), 20.0),
    (0.45, 35.0, -4.0, (0.60, -0.08), -35.0),
    (0.20, 15.0, 1.5, (0.45, 0.02), 90.0),
])
def test_floor_recovers_mounting(tmp_path, capsys, height, tilt, roll,
                                 origin, yaw):
    camera = Camera(WIDTH, HEIGHT, fx=580.0, fy=580.0, cx=318.2, cy=241.6,
                    height_m=height, tilt_deg=tilt, roll_deg=roll)
    image = _floor_image(camera, origin, yaw, tmp_path / "floor.png")
    intrinsics = _write_intrinsics(camera, tmp_path / "camera.yml")
    out = tmp_path / "mounted.yml"
    status = main(["calibrate", "floor", image, "--pattern", "9x6",
                   "--square", str(SQUARE), "--camera", intrinsics,
                   "--origin", f"{origin[0] + 0.1},{origin[1]}", "-o",
                   str(out)])
    assert status == 0
    text = capsys.readouterr().out
    assert "height" in text and "tilt" in text and "roll" in text
    # --origin says the board centre is 0.1 m further ahead than it is
    # from the camera's floor point: the camera sits 0.1 m ahead.
    line = [row for row in text.splitlines() if "--origin" in row][0]
    words = line.split()
    fwd = float(words[words.index("forward") + 1])
    left = float(words[words.index("left") + 1])
    assert fwd == pytest.approx(0.1, abs=0.01)
    assert left == pytest.approx(0.0, abs=0.01)
    fs = cv2.FileStorage(str(out), cv2.FILE_STORAGE_READ)
    got_h = fs.getNode("camera_height").real()
    got_t = fs.getNode("tilt_deg").real()
    got_r = fs.getNode("roll_deg").real()
    np.testing.assert_allclose(fs.getNode("camera_matrix").mat(),
                               camera.matrix)
    assert fs.getNode("distortion_coefficients").mat().shape == (1, 5)
    fs.release()
    assert got_h == pytest.approx(height, abs=0.01)
    assert got_t == pytest.approx(tilt, abs=0.3)
    assert got_r == pytest.approx(roll, abs=0.3)


def test_floor_pose_exact_corners():
    """On exactly projected corners the pose is exact (sign conventions
    of tilt and roll, either detector ordering)."""
    camera = Camera(WIDTH, HEIGHT, hfov_deg=60.0, height_m=0.35,
                    tilt_deg=28.0, roll_deg=-6.0)
    board = calibrate.board_points(PATTERN, SQUARE).astype(np.float64)
    world = board + np.array([0.5, -0.1, 0.0])
    uv, _ = camera.project(world, Pose(0.0, 0.0, 0.0))
    cam = {"camera_matrix": camera.matrix, "dist": np.zeros(5)}
    for corners in (uv, uv[::-1]):
        result = calibrate.floor_pose(
            corners.reshape(-1, 1, 2).astype(np.float32), PATTERN, SQUARE,
            cam, thickness=0.0)
        assert result.height == pytest.approx(0.35, abs=1e-4)
        assert result.tilt_deg == pytest.approx(28.0, abs=1e-3)
        assert result.roll_deg == pytest.approx(-6.0, abs=1e-3)
        middle = world.mean(axis=0)
        assert result.centre_robot == pytest.approx(
            (middle[0], middle[1]), abs=1e-4)


def test_mounting_from_up_signs():
    # Tilted down, no roll: up is towards -y_c (image up) and -z_c.
    tilt, roll = calibrate.mounting_from_up(
        [0.0, -math.cos(0.3), -math.sin(0.3)])
    assert tilt == pytest.approx(0.3) and roll == pytest.approx(0.0)
    # Rolled clockwise (from behind): up leans towards image left (-x_c).
    rot = calibrate.robot_to_camera_rotation(0.2, 0.1)
    tilt, roll = calibrate.mounting_from_up(rot @ np.array([0, 0, 1.0]))
    assert tilt == pytest.approx(0.2) and roll == pytest.approx(0.1)
    assert (rot @ np.array([0, 0, 1.0]))[0] < 0
    np.testing.assert_allclose(
        rot, Camera(tilt_deg=math.degrees(0.2),
                    roll_deg=math.degrees(0.1)).robot_to_camera())


def test_floor_errors(tmp_path, capsys):
    camera = Camera(WIDTH, HEIGHT, hfov_deg=60.0, height_m=0.3,
                    tilt_deg=25.0)
    intrinsics = _write_intrinsics(camera, tmp_path / "camera.yml")
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((HEIGHT, WIDTH), 90, np.uint8))
    out = str(tmp_path / "out.yml")
    base = ["calibrate", "floor", str(blank), "--pattern", "9x6",
            "--square", "0.025", "--camera", intrinsics, "-o", out]
    assert main(base) == 1
    assert f"pattern 9x6 not found in image 1 ({blank})" in \
        capsys.readouterr().err
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.zeros((240, 320), np.uint8))
    assert main(base[:2] + [str(small)] + base[3:]) == 1
    assert "320x240" in capsys.readouterr().err
    seed = tmp_path / "seed.yml"
    assert main(["calibrate", "seed", "--height", "0.3", "--blind", "0.2",
                 "--depth", "0.6", "--half-width", "0.4", "-o",
                 str(seed)]) == 0
    capsys.readouterr()
    argv = list(base)
    argv[argv.index("--camera") + 1] = str(seed)
    assert main(argv) == 1
    assert "no 3x3 'camera_matrix'" in capsys.readouterr().err
    argv[argv.index("--camera") + 1] = str(tmp_path / "none.yml")
    assert main(argv) == 1
    assert "no such file" in capsys.readouterr().err
    assert main(base[:-2]) == 2          # -o is required


def test_chessboard_then_floor(board_images, tmp_path, capsys):
    """The whole chain through the command line: intrinsics from the
    boards, then the mounting, written back to the same file."""
    out = tmp_path / "camera.yml"
    assert main(["calibrate", "chessboard", *board_images, "--pattern",
                 "9x6", "--square", str(SQUARE), "-o", str(out)]) == 0
    camera = Camera(WIDTH, HEIGHT, fx=TRUE_K[0, 0], fy=TRUE_K[1, 1],
                    cx=TRUE_K[0, 2], cy=TRUE_K[1, 2], height_m=0.32,
                    tilt_deg=30.0, roll_deg=2.0)
    image = _floor_image(camera, (0.5, 0.03), 10.0, tmp_path / "floor.png")
    assert main(["calibrate", "floor", image, "--pattern", "9x6",
                 "--square", str(SQUARE), "--camera", str(out), "-o",
                 str(out)]) == 0
    capsys.readouterr()
    mounted = calibrate.read_camera_file(str(out))
    assert mounted["nr_of_frames"] == len(board_images)
    fs = cv2.FileStorage(str(out), cv2.FILE_STORAGE_READ)
    assert fs.getNode("camera_height").real() == pytest.approx(0.32,
                                                               abs=0.01)
    assert fs.getNode("tilt_deg").real() == pytest.approx(30.0, abs=0.3)
    assert fs.getNode("roll_deg").real() == pytest.approx(2.0, abs=0.3)
    fs.release()


def test_camera_file_xml_and_thickness(tmp_path):
    """XML files (the other FileStorage format) read back; the board's
    thickness adds to the height."""
    camera = Camera(WIDTH, HEIGHT, hfov_deg=60.0, height_m=0.3,
                    tilt_deg=25.0)
    path = _write_intrinsics(camera, tmp_path / "camera.xml")
    assert open(path).read().startswith("<?xml")
    cam = calibrate.read_camera_file(path)
    np.testing.assert_allclose(cam["camera_matrix"], camera.matrix)
    assert (cam["image_width"], cam["image_height"]) == (WIDTH, HEIGHT)
    world = calibrate.board_points(PATTERN, SQUARE) + np.array(
        [0.5, 0.0, 0.0], dtype=np.float32)
    uv, _ = camera.project(world, Pose(0.0, 0.0, 0.0))
    corners = uv.reshape(-1, 1, 2).astype(np.float32)
    thin = calibrate.floor_pose(corners, PATTERN, SQUARE, cam)
    thick = calibrate.floor_pose(corners, PATTERN, SQUARE, cam,
                                 thickness=0.004)
    assert thick.height - thin.height == pytest.approx(0.004)


# ---------------------------------------------------------------------------
# ROS camera_info YAML: calibrate camera-info writes it, the camera file
# reader reads it (its checks are the elements' loader's: the cases with
# ipmrange are in test_ipmrange.py)

INFO_K = np.array([[612.37, 0.0, 322.71], [0.0, 608.52, 236.14],
                   [0.0, 0.0, 1.0]])
INFO_DIST = np.array([-0.1216, 0.0311, 0.00042, -0.00019, 1.7e-05])


def _opencv_camera_file(path, dist=INFO_DIST, mounting=True):
    """A camera file as calibrate chessboard + floor write it."""
    camera = {calibrate.K_MATRIX: INFO_K, "dist": dist,
              calibrate.K_WIDTH: WIDTH, calibrate.K_HEIGHT: HEIGHT}
    fields = calibrate._intrinsic_fields(camera)
    if mounting:
        fields.update(camera_height=0.315, tilt_deg=26.5, roll_deg=-1.25)
    calibrate.write_camera_file(str(path), fields)
    return str(path)


@pytest.mark.parametrize("dist, model", [
    (INFO_DIST, "plumb_bob"),
    (INFO_DIST[:4], "plumb_bob"),
    (np.r_[INFO_DIST, 0.002, -0.0007, 0.0001], "rational_polynomial"),
    (np.r_[INFO_DIST, 0.002, -0.0007, 0.0001, 0.0, 0.0, 0.0, 0.0],
     "rational_polynomial"),
])
def test_camera_info_cli(tmp_path, capsys, dist, model):
    """calibrate camera-info: ROS's layout and keys; read back, the
    intrinsics, distortion and mounting are those of the camera file."""
    source = _opencv_camera_file(tmp_path / "camera.yml", dist)
    out = tmp_path / "camera_info.yaml"
    assert main(["calibrate", "camera-info", source, "-o", str(out)]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    text = out.read_text()
    lines = text.splitlines()
    assert lines[:4] == ["image_width: 640", "image_height: 480",
                         "camera_name: camera", "camera_matrix:"]
    assert f"distortion_model: {model}" in lines
    assert not text.startswith("%YAML")
    back = calibrate.read_camera_file(str(out))
    want = calibrate.read_camera_file(source)
    np.testing.assert_allclose(back["camera_matrix"], want["camera_matrix"],
                               rtol=0, atol=1e-9)
    n = 5 if model == "plumb_bob" else 8
    expect = np.r_[dist, np.zeros(max(0, n - len(dist)))][:n]
    np.testing.assert_allclose(back["dist"], expect, rtol=0, atol=1e-12)
    assert (back["image_width"], back["image_height"]) == (WIDTH, HEIGHT)
    assert back["distortion_model"] == model
    assert calibrate.read_mounting(str(out)) == pytest.approx(
        {"camera_height": 0.315, "tilt_deg": 26.5, "roll_deg": -1.25},
        abs=1e-12)


def test_camera_info_is_yaml_as_ros_reads_it(tmp_path):
    """Read by a YAML parser of its own (PyYAML, what ROS's Python tools
    use; YAML 1.1, where 1e-05 would be a string): every key
    camera_calibration_parsers reads, numbers as numbers, rows x cols
    values; P = [K | 0], R the identity."""
    yaml = pytest.importorskip("yaml")
    source = _opencv_camera_file(tmp_path / "camera.yml")
    out = tmp_path / "camera_info.yaml"
    assert main(["calibrate", "camera-info", source, "--name",
                 "head_camera", "-o", str(out)]) == 0
    doc = yaml.safe_load(out.read_text())
    assert doc["image_width"] == WIDTH and doc["image_height"] == HEIGHT
    assert doc["camera_name"] == "head_camera"
    assert doc["distortion_model"] == "plumb_bob"
    for key, rows, cols in (("camera_matrix", 3, 3),
                            ("distortion_coefficients", 1, 5),
                            ("rectification_matrix", 3, 3),
                            ("projection_matrix", 3, 4)):
        m = doc[key]
        assert (m["rows"], m["cols"]) == (rows, cols)
        assert len(m["data"]) == rows * cols
        assert all(isinstance(v, float) for v in m["data"]), m["data"]
    np.testing.assert_array_equal(
        np.reshape(doc["camera_matrix"]["data"], (3, 3)), INFO_K)
    np.testing.assert_array_equal(doc["distortion_coefficients"]["data"],
                                  INFO_DIST)
    np.testing.assert_array_equal(
        np.reshape(doc["projection_matrix"]["data"], (3, 4)),
        np.hstack([INFO_K, np.zeros((3, 1))]))
    np.testing.assert_array_equal(doc["rectification_matrix"]["data"],
                                  np.eye(3).ravel())
    assert doc["camera_height"] == 0.315


def test_camera_info_keeps_its_name(tmp_path, capsys):
    """A camera_info file converted again keeps its camera_name (and a
    floor calibration can start from one)."""
    source = _opencv_camera_file(tmp_path / "camera.yml", mounting=False)
    first = tmp_path / "a.yaml"
    assert main(["calibrate", "camera-info", source, "--name", "elp/left",
                 "-o", str(first)]) == 0
    second = tmp_path / "b.yaml"
    assert main(["calibrate", "camera-info", str(first), "-o",
                 str(second)]) == 0
    assert "camera_name: elp/left" in second.read_text().splitlines()
    assert calibrate.read_camera_file(str(second))["camera_name"] == \
        "elp/left"
    assert calibrate.read_mounting(str(second)) == {}
    capsys.readouterr()


def test_camera_info_cli_errors(tmp_path, capsys):
    seed = tmp_path / "seed.yml"
    assert main(["calibrate", "seed", "--height", "0.3", "--blind", "0.2",
                 "--depth", "0.6", "--half-width", "0.4", "-o",
                 str(seed)]) == 0
    capsys.readouterr()
    out = str(tmp_path / "info.yaml")
    assert main(["calibrate", "camera-info", str(seed), "-o", out]) == 1
    assert "no 3x3 'camera_matrix'" in capsys.readouterr().err
    # thin-prism coefficients: no ROS model holds them
    prism = _opencv_camera_file(tmp_path / "prism.yml",
                                np.r_[INFO_DIST, 0.0, 0.0, 0.0, 0.001, 0.0,
                                      0.0, 0.0])
    assert main(["calibrate", "camera-info", prism, "-o", out]) == 1
    assert "12 distortion coefficients have no ROS distortion model" in \
        capsys.readouterr().err
    good = _opencv_camera_file(tmp_path / "camera.yml")
    assert main(["calibrate", "camera-info", good, "--name", "left cam",
                 "-o", out]) == 2
    assert "a camera name takes letters" in capsys.readouterr().err
    assert main(["calibrate", "camera-info", good, "-o",
                 str(tmp_path / "no" / "info.yaml")]) == 1
    assert "cannot write" in capsys.readouterr().err


# As ROS's tools write them: camera_calibration_parsers (yaml-cpp) and the
# camera_calibration GUI (lists over lines in numpy's spacing, 4-space
# indents in older versions)
ROS_YAML_CPP = """\
image_width: 640
image_height: 480
camera_name: 00b09d0100990bb6
camera_matrix:
  rows: 3
  cols: 3
  data: [538.63, 0, 317.698, 0, 539.723, 241.003, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.30678, 0.0825017, 0.0028784, -1.5829e-05, 0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [538.63, 0, 317.698, 0, 0, 539.723, 241.003, 0, 0, 0, 1, 0]
"""
ROS_GUI = """\
image_width: 1280
image_height: 800
camera_name: narrow_stereo
camera_matrix:
    rows: 3
    cols: 3
    data: [ 415.12614,    0.     ,  665.52373,
              0.     ,  410.49986,  460.14929,
              0.     ,    0.     ,    1.     ]
distortion_model: rational_polynomial
distortion_coefficients:
    rows: 1
    cols: 8
    data: [-0.017697, -0.007270, 0.005751, -0.000139, 0., 0.1, 0.2, 0.3]
rectification_matrix:
    rows: 3
    cols: 3
    data: [1., 0., 0.,
           0., 1., 0.,
           0., 0., 1.]
"""


def test_read_camera_info_as_ros_writes_it(tmp_path):
    path = tmp_path / "a.yaml"
    path.write_text(ROS_YAML_CPP)
    cam = calibrate.read_camera_file(str(path))
    np.testing.assert_array_equal(cam["camera_matrix"], [
        [538.63, 0, 317.698], [0, 539.723, 241.003], [0, 0, 1]])
    np.testing.assert_array_equal(cam["dist"], [-0.30678, 0.0825017,
                                                0.0028784, -1.5829e-05, 0])
    assert (cam["image_width"], cam["image_height"]) == (640, 480)
    assert cam["camera_name"] == "00b09d0100990bb6"
    assert calibrate.read_mounting(str(path)) == {}
    path.write_text(ROS_GUI.replace("\n", "\r\n"))
    cam = calibrate.read_camera_file(str(path))
    np.testing.assert_array_equal(cam["camera_matrix"], [
        [415.12614, 0, 665.52373], [0, 410.49986, 460.14929], [0, 0, 1]])
    np.testing.assert_array_equal(cam["dist"], [-0.017697, -0.007270,
                                                0.005751, -0.000139, 0.0,
                                                0.1, 0.2, 0.3])
    assert cam["distortion_model"] == "rational_polynomial"
    assert (cam["image_width"], cam["image_height"]) == (1280, 800)


def test_console_tunes_a_camera_info_file(tmp_path):
    """The console's copy of a camera file for tuning (ipmrange reads the
    copy) stays camera_info, with the mounting replaced."""
    from gstlandmark.commands.console import engine
    source = tmp_path / "camera_info.yaml"
    source.write_text(ROS_YAML_CPP + "camera_height: 0.3\ntilt_deg: 20\n")
    assert engine.read_camera_mounting(str(source)) == {
        "camera-height": 0.3, "tilt": 20.0}
    copy = tmp_path / "copy.yaml"
    engine.copy_camera_file(str(source), str(copy), {"tilt_deg": 24.5})
    assert calibrate.read_mounting(str(copy)) == {"camera_height": 0.3,
                                                  "tilt_deg": 24.5}
    cam = calibrate.read_camera_file(str(copy))
    assert cam["camera_name"] == "00b09d0100990bb6"
    assert cam["camera_matrix"][0, 0] == 538.63
