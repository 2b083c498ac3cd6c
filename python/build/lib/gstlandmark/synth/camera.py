"""The robot's pinhole camera and pose, exactly as docs/conventions.md
defines them (robot frame x forward, y left, z up; OpenCV camera axes)."""

from dataclasses import dataclass
import math

import numpy as np


def wrap_angle(angle):
    """Wrap an angle in radians to (-pi, pi]."""
    return math.pi - (math.pi - angle) % (2.0 * math.pi)


@dataclass(frozen=True)
class Pose:
    """Robot pose: the camera's floor point (x, y) and heading (rad, from
    world +x towards +y)."""

    x: float
    y: float
    heading: float

    def to_json(self):
        return {"x": round(float(self.x), 6), "y": round(float(self.y), 6),
                "heading": round(wrap_angle(float(self.heading)), 7)}


def world_to_robot_matrix(heading):
    """Rows: the robot's forward, left and up axes in world coordinates."""
    c, s = math.cos(heading), math.sin(heading)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def ground_coordinates(pose, x, y):
    """Robot-frame (gx, gy), range and bearing of a world floor point."""
    dx, dy = x - pose.x, y - pose.y
    c, s = math.cos(pose.heading), math.sin(pose.heading)
    gx = c * dx + s * dy
    gy = -s * dx + c * dy
    return gx, gy, math.hypot(gx, gy), math.atan2(gy, gx)


class Camera:
    """Pinhole camera at height ``height_m`` over the robot's reference
    point, looking forward, tilted down by ``tilt_deg``, rolled by
    ``roll_deg``.

    Give either ``hfov_deg`` or ``fx`` (``fy`` defaults to ``fx``, the
    principal point to the image centre ``((W - 1) / 2, (H - 1) / 2)``).
    """

    def __init__(self, width=640, height=480, hfov_deg=60.0, fx=None,
                 fy=None, cx=None, cy=None, height_m=0.30, tilt_deg=25.0,
                 roll_deg=0.0):
        if width < 1 or height < 1:
            raise ValueError(f"bad image size {width}x{height}")
        self.width = int(width)
        self.height = int(height)
        if fx is None:
            if not 0.0 < hfov_deg < 180.0:
                raise ValueError(f"hfov must be within (0, 180) degrees, "
                                 f"got {hfov_deg}")
            fx = (self.width / 2.0) / math.tan(math.radians(hfov_deg) / 2)
        self.fx = float(fx)
        self.fy = float(fy if fy is not None else fx)
        self.cx = float(cx if cx is not None else (self.width - 1) / 2.0)
        self.cy = float(cy if cy is not None else (self.height - 1) / 2.0)
        if self.fx <= 0 or self.fy <= 0:
            raise ValueError("focal lengths must be positive")
        self.height_m = float(height_m)
        self.tilt_deg = float(tilt_deg)
        self.roll_deg = float(roll_deg)

    @property
    def hfov_deg(self):
        return math.degrees(2.0 * math.atan((self.width / 2.0) / self.fx))

    @property
    def matrix(self):
        """OpenCV camera matrix K."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy],
                         [0.0, 0.0, 1.0]])

    def robot_to_camera(self):
        """Rotation whose rows are x_c', y_c', z_c in the robot frame."""
        t = math.radians(self.tilt_deg)
        r = math.radians(self.roll_deg)
        x_c = np.array([0.0, -1.0, 0.0])
        y_c = np.array([-math.sin(t), 0.0, -math.cos(t)])
        z_c = np.array([math.cos(t), 0.0, -math.sin(t)])
        return np.array([math.cos(r) * x_c + math.sin(r) * y_c,
                         -math.sin(r) * x_c + math.cos(r) * y_c,
                         z_c])

    def world_to_camera(self, pose):
        """(R_wc, C): world-to-camera rotation and the camera centre in
        world coordinates."""
        rot = self.robot_to_camera() @ world_to_robot_matrix(pose.heading)
        centre = np.array([pose.x, pose.y, self.height_m])
        return rot, centre

    def rvec_tvec(self, pose):
        """rvec, tvec for cv2.projectPoints of world points."""
        import cv2
        rot, centre = self.world_to_camera(pose)
        rvec, _ = cv2.Rodrigues(rot)
        return rvec.ravel(), -rot @ centre

    def to_camera(self, points, pose):
        """World points (N, 3) to camera coordinates (N, 3)."""
        rot, centre = self.world_to_camera(pose)
        return (np.asarray(points, dtype=np.float64) - centre) @ rot.T

    def project(self, points, pose):
        """World points (N, 3) -> pixels (N, 2) and camera depth (N,).
        Pixels of points at or behind the camera plane are NaN."""
        pc = self.to_camera(points, pose)
        z = pc[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            safe = np.where(z > 1e-12, z, np.nan)
            uv = np.stack([self.fx * pc[:, 0] / safe + self.cx,
                           self.fy * pc[:, 1] / safe + self.cy], axis=1)
        return uv, z

    def pixel_directions(self, u, v):
        """Camera-frame ray directions (N, 3) through pixel positions,
        scaled so that their z_c component is 1."""
        u = np.asarray(u, dtype=np.float64).ravel()
        v = np.asarray(v, dtype=np.float64).ravel()
        return np.stack([(u - self.cx) / self.fx, (v - self.cy) / self.fy,
                         np.ones_like(u)], axis=1)

    def to_json(self):
        return {"width": self.width, "height": self.height,
                "fx": round(self.fx, 6), "fy": round(self.fy, 6),
                "cx": round(self.cx, 6), "cy": round(self.cy, 6),
                "hfov_deg": round(self.hfov_deg, 6),
                "height_m": self.height_m, "tilt_deg": self.tilt_deg,
                "roll_deg": self.roll_deg}

    def __repr__(self):
        return (f"Camera({self.width}x{self.height}, fx={self.fx:.2f}, "
                f"fy={self.fy:.2f}, cx={self.cx:.2f}, cy={self.cy:.2f}, "
                f"height_m={self.height_m}, tilt_deg={self.tilt_deg}, "
                f"roll_deg={self.roll_deg})")
