"""Test frames: random and natural-looking images, packed into any of the
formats labsegment accepts, with the reference's view of the same pixels."""

import numpy as np

import gi

gi.require_version("Gst", "1.0")
gi.require_version("GstVideo", "1.0")
from gi.repository import Gst, GstVideo  # noqa: E402

from gstlandmark import reference  # noqa: E402

PACKED_ORDER = {
    # format: byte position of R, G, B in a pixel, and pixel size
    "RGB": ((0, 1, 2), 3), "BGR": ((2, 1, 0), 3),
    "RGBx": ((0, 1, 2), 4), "BGRx": ((2, 1, 0), 4),
    "xRGB": ((1, 2, 3), 4), "xBGR": ((3, 2, 1), 4),
    "RGBA": ((0, 1, 2), 4), "BGRA": ((2, 1, 0), 4),
}
YUV_FORMATS = ("I420", "NV12", "YUY2")
ALL_FORMATS = tuple(PACKED_ORDER) + YUV_FORMATS

COLORIMETRY = {
    # caps colorimetry: (reference matrix, full range)
    "bt601": ("bt601", False),
    "bt709": ("bt709", False),
    "1:4:0:0": ("bt601", True),     # full-range BT.601 (JPEG)
}


def natural_rgb(rng, height, width):
    """A floor-like scene: smooth shading, coloured discs with soft edges,
    sensor noise. Many pixels lie between classes, as in real video."""
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float64)
    base = 90 + 80 * (yy / max(height - 1, 1)) + 20 * np.sin(xx / 7.0)
    img = np.stack([base * 1.02, base, base * 0.95], -1)
    colours = [(200, 40, 40), (60, 190, 70), (230, 220, 60), (240, 100, 170),
               (40, 70, 200), (240, 240, 240)]
    for _ in range(8):
        cx, cy = rng.uniform(0, width), rng.uniform(0, height)
        r = rng.uniform(2, max(3, min(width, height) / 4))
        c = np.array(colours[rng.integers(len(colours))], np.float64)
        d = np.hypot(xx - cx, (yy - cy) * 1.6)
        alpha = np.clip(r - d + 0.5, 0, 1)[..., None]
        img = img * (1 - alpha) + c * alpha
    img += rng.normal(0, 6, img.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def random_rgb(rng, height, width):
    return rng.integers(0, 256, (height, width, 3), dtype=np.uint8)


def caps_string(fmt, width, height, colorimetry=None):
    caps = (f"video/x-raw,format={fmt},width={width},height={height},"
            "framerate=30/1")
    if colorimetry:
        caps += f",colorimetry={colorimetry}"
    return caps


def video_info(caps):
    return GstVideo.VideoInfo.new_from_caps(Gst.Caps.from_string(caps))


def pack_rgb(rgb, fmt, info, rng):
    """An RGB image as the bytes of a packed-RGB frame (default strides),
    with random bytes in the x/A positions and the row padding."""
    (ro, go, bo), ps = PACKED_ORDER[fmt]
    h, w, _ = rgb.shape
    stride = info.stride[0]
    data = rng.integers(0, 256, (h, stride), dtype=np.uint8)
    pix = data[:, :w * ps].reshape(h, w, ps)
    pix[..., ro], pix[..., go], pix[..., bo] = (rgb[..., 0], rgb[..., 1],
                                                rgb[..., 2])
    return data.tobytes()


def random_yuv(rng, fmt, info):
    """Random bytes laid out as a YUV frame, and the frame's components
    (Y, U, V) per pixel for the reference."""
    data = rng.integers(0, 256, info.size, dtype=np.uint8)
    return data.tobytes(), yuv_components(data, fmt, info)


def yuv_components(data, fmt, info):
    w, h = info.width, info.height
    cw, ch = (w + 1) // 2, (h + 1) // 2
    if fmt == "YUY2":
        rows = np.stack([data[info.offset[0] + y * info.stride[0]:]
                         [:cw * 4] for y in range(h)])
        return ("YUY2", rows, w)
    y = np.stack([data[info.offset[0] + r * info.stride[0]:][:w]
                  for r in range(h)])
    if fmt == "I420":
        u = np.stack([data[info.offset[1] + r * info.stride[1]:][:cw]
                      for r in range(ch)])
        v = np.stack([data[info.offset[2] + r * info.stride[2]:][:cw]
                      for r in range(ch)])
        return ("I420", y, u, v)
    uv = np.stack([data[info.offset[1] + r * info.stride[1]:][:2 * cw]
                   for r in range(ch)])
    return ("NV12", y, uv)


def yuv_to_rgb_float(components, matrix, full_range):
    kind = components[0]
    if kind == "YUY2":
        return reference.yuy2_to_rgb_float(components[1], components[2],
                                           matrix=matrix,
                                           full_range=full_range)
    if kind == "I420":
        return reference.i420_planes_to_rgb_float(
            *components[1:], matrix=matrix, full_range=full_range)
    return reference.nv12_to_rgb_float(*components[1:], matrix=matrix,
                                       full_range=full_range)


def rgb_to_yuv_bytes(rgb, fmt, info):
    """Natural RGB content as a YUV frame (BT.601 limited range), so YUV
    formats see realistic colours too."""
    f = rgb.astype(np.float64) / 255.0
    kr, kb = 0.299, 0.114
    y = kr * f[..., 0] + (1 - kr - kb) * f[..., 1] + kb * f[..., 2]
    cb = (f[..., 2] - y) / (2 * (1 - kb))
    cr = (f[..., 0] - y) / (2 * (1 - kr))
    Y = np.clip(np.rint(16 + 219 * y), 0, 255).astype(np.uint8)
    U = np.clip(np.rint(128 + 224 * cb), 0, 255).astype(np.uint8)
    V = np.clip(np.rint(128 + 224 * cr), 0, 255).astype(np.uint8)
    h, w = Y.shape
    cw, ch = (w + 1) // 2, (h + 1) // 2
    pad = np.pad  # chroma takes the top-left sample of each block
    Us = pad(U, ((0, 2 * ch - h), (0, 2 * cw - w)), mode="edge")[::2, ::2]
    Vs = pad(V, ((0, 2 * ch - h), (0, 2 * cw - w)), mode="edge")[::2, ::2]
    data = np.zeros(info.size, np.uint8)
    if fmt == "YUY2":
        # 4:2:2: every row has its own chroma, shared by pixel pairs
        Yp = pad(Y, ((0, 0), (0, 2 * cw - w)), mode="edge")
        Uh = pad(U, ((0, 0), (0, 2 * cw - w)), mode="edge")[:, ::2]
        Vh = pad(V, ((0, 0), (0, 2 * cw - w)), mode="edge")[:, ::2]
        for r in range(h):
            row = np.empty(cw * 4, np.uint8)
            row[0::4], row[2::4] = Yp[r, 0::2], Yp[r, 1::2]
            row[1::4], row[3::4] = Uh[r], Vh[r]
            start = info.offset[0] + r * info.stride[0]
            data[start:start + cw * 4] = row
        return data.tobytes()
    for r in range(h):
        start = info.offset[0] + r * info.stride[0]
        data[start:start + w] = Y[r]
    for r in range(ch):
        if fmt == "I420":
            s1 = info.offset[1] + r * info.stride[1]
            s2 = info.offset[2] + r * info.stride[2]
            data[s1:s1 + cw], data[s2:s2 + cw] = Us[r], Vs[r]
        else:
            s1 = info.offset[1] + r * info.stride[1]
            data[s1:s1 + 2 * cw:2], data[s1 + 1:s1 + 2 * cw:2] = Us[r], Vs[r]
    return data.tobytes()
