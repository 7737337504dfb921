"""What the real bottom camera does to the image MuJoCo renders, ROS-free and cheap (about 1 ms a frame).

- Lens distortion (plumb_bob: k1, k2, p1, p2, k3, as camera_info D): MuJoCo renders a perfect pinhole
  image with a field of view wide enough for the distorted image's corners, and each output pixel is
  fetched from where the lens would have imaged it (one precomputed remap).
- Motion blur: the image moves during the exposure (the drone's rotation, and its motion relative to
  the surface below at that distance); a line kernel along that motion, its length the displacement.
- Exposure: a slowly wandering gain (auto-exposure lagging changes of light), and sensor noise.
"""
import math

import cv2
import numpy as np


class Lens:
    """Maps the pinhole render to the distorted image. ``intrinsics`` (width, height, fx, fy, cx, cy) of the
    output image, ``distortion`` (k1, k2, p1, p2, k3)."""

    def __init__(self, intrinsics, distortion):
        width, height, fx, fy, cx, cy = intrinsics
        self.width, self.height = width, height
        self.distortion = tuple(float(v) for v in distortion)
        self.identity = not any(self.distortion)
        self.render_focal = fy
        self.maps = None
        if self.identity:
            return
        camera = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        u, v = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
        pixels = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
        # Where each distorted pixel's ray points, as a normalised pinhole coordinate.
        rays = cv2.undistortPointsIter(pixels, camera, np.array(self.distortion), None, None,
                                       (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-9))
        rays = rays.reshape(height, width, 2)
        # A render focal length at which every such ray still lands inside the rendered image.
        half_w, half_h = (width - 1) / 2.0, (height - 1) / 2.0
        reach_x, reach_y = np.abs(rays[..., 0]).max(), np.abs(rays[..., 1]).max()
        self.render_focal = min(fy, half_w / reach_x, half_h / reach_y)
        map_x = (self.render_focal * rays[..., 0] + half_w).astype(np.float32)
        map_y = (self.render_focal * rays[..., 1] + half_h).astype(np.float32)
        self.maps = cv2.convertMaps(map_x, map_y, cv2.CV_16SC2)

    @property
    def render_fovy_deg(self):
        """Vertical field of view to render with [deg]."""
        return math.degrees(2.0 * math.atan((self.height / 2.0) / self.render_focal))

    def apply(self, rendered):
        if self.identity:
            return rendered
        return cv2.remap(rendered, self.maps[0], self.maps[1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def image_motion(focal_px, exposure_s, velocity_camera, rate_camera, distance):
    """Displacement (du, dv) [px] of the image centre during the exposure: the camera moves at
    ``velocity_camera`` (optical frame: x right, y down, z forward) [m/s] relative to the surface
    ``distance`` [m] ahead, and turns at ``rate_camera`` (optical frame) [rad/s]. A point on the optical
    axis moves at u' = f (-vx / Z - wy), v' = f (-vy / Z + wx)."""
    z = max(0.05, distance) if math.isfinite(distance) else math.inf
    du = -velocity_camera[0] / z - rate_camera[1]
    dv = -velocity_camera[1] / z + rate_camera[0]
    return focal_px * exposure_s * du, focal_px * exposure_s * dv


def motion_blur(image, du, dv, min_length=0.75):
    """``image`` smeared along (du, dv) [px]: the mean of its copies along that segment."""
    length = math.hypot(du, dv)
    if length < min_length:
        return image
    size = 2 * int(math.ceil(length / 2.0)) + 1
    kernel = np.zeros((size, size), np.float32)
    centre = size // 2
    # Anti-aliased segment, centred: the kernel is point-symmetric, so the sign of the motion does not matter.
    shift = 4  # sub-pixel bits of cv2.line
    scale = 1 << shift
    start = (int(round((centre - du / 2.0) * scale)), int(round((centre - dv / 2.0) * scale)))
    end = (int(round((centre + du / 2.0) * scale)), int(round((centre + dv / 2.0) * scale)))
    cv2.line(kernel, start, end, 1.0, 1, cv2.LINE_AA, shift)
    kernel /= kernel.sum()
    return cv2.filter2D(image, -1, kernel, borderType=cv2.BORDER_REPLICATE)


class Exposure:
    """Brightness gain that wanders (Gauss-Markov on its logarithm) and sensor noise (normal, std
    ``noise_std`` of full scale). The noise comes from a bank of seeded frames read at random offsets:
    drawing 230,000 normal numbers a frame cost 3 ms."""

    BANK_FRAMES = 8
    MARGIN = 32

    def __init__(self, rng, shape, gain_std, time_constant, noise_std):
        self.rng, self.gain_std, self.time_constant = rng, gain_std, time_constant
        self.log_gain = gain_std * rng.standard_normal() if gain_std > 0.0 else 0.0
        self.time = None
        self.bank = None
        if noise_std > 0.0:
            height, width = shape[0] + self.MARGIN, shape[1] + self.MARGIN
            noise = rng.normal(0.0, 255.0 * noise_std, (self.BANK_FRAMES, height, width) + tuple(shape[2:]))
            noise = np.clip(np.round(noise), -255, 255)
            # As two unsigned parts: OpenCV's saturating add and subtract on uint8 are the fastest path.
            self.bank = (np.maximum(noise, 0).astype(np.uint8), np.maximum(-noise, 0).astype(np.uint8))
        self.shape = shape

    def gain(self, t):
        if self.gain_std <= 0.0:
            return 1.0
        if self.time is not None and t > self.time:
            decay = math.exp(-(t - self.time) / self.time_constant)
            self.log_gain = decay * self.log_gain + self.gain_std * math.sqrt(1 - decay * decay) * \
                self.rng.standard_normal()
        self.time = t
        return math.exp(self.log_gain)

    def apply(self, image, t):
        gain = self.gain(t)
        if gain != 1.0:
            image = cv2.convertScaleAbs(image, alpha=gain)
        if self.bank is not None:
            k = int(self.rng.integers(self.BANK_FRAMES))
            dy, dx = (int(v) for v in self.rng.integers(self.MARGIN, size=2))
            h, w = self.shape[0], self.shape[1]
            image = cv2.add(image, self.bank[0][k, dy:dy + h, dx:dx + w])
            image = cv2.subtract(image, self.bank[1][k, dy:dy + h, dx:dx + w])
        return image
