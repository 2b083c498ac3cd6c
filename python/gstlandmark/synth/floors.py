"""Floor textures: periodic images on the floor plane, sampled through a
mip pyramid so that far, grazing floor does not alias into moire."""

import math

import numpy as np

from .. import reference

# name -> (description, plain sRGB colour or None for a generated texture)
FLOORS = {
    "grey": ("plain mid grey", (128, 128, 128)),
    "white": ("plain white", (232, 232, 228)),
    "dark": ("plain near-black", (44, 44, 47)),
    "wood": ("wooden planks 15 cm x 1.2 m with grain", None),
    "carpet": ("grey-beige carpet noise", None),
    "tiles": ("30 cm ceramic tiles with grout", None),
    "red": ("plain red", (168, 46, 40)),
    "orange": ("plain orange", (216, 122, 46)),
}
FLOOR_NAMES = tuple(FLOORS)


def srgb8_to_linear(srgb):
    """sRGB (0..255) to linear light (0..1), float32."""
    c = np.asarray(srgb, dtype=np.float64) / 255.0
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return lin.astype(np.float32)


def linear_to_srgb(lin):
    """Linear light (0..1) to sRGB (0..1), float64."""
    c = np.clip(np.asarray(lin, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c,
                    1.055 * c ** (1 / 2.4) - 0.055)


def _periodic_blur(noise, sigma_texels):
    """Gaussian blur that wraps around (the texture tiles seamlessly)."""
    h, w = noise.shape
    fy = np.fft.fftfreq(h)[:, None]
    fx = np.fft.rfftfreq(w)[None, :]
    gain = np.exp(-2.0 * (math.pi * sigma_texels) ** 2 * (fx ** 2 + fy ** 2))
    out = np.fft.irfft2(np.fft.rfft2(noise) * gain, s=(h, w))
    return out / (out.std() + 1e-12)


def _wood(rng):
    # 5 mm texels; 8 rows of planks 15 cm wide, 2.4 m period along x.
    texel = 0.005
    rows, width, length = 8, 30, 240
    h, w = rows * width, 2 * length
    iy, ix = np.mgrid[0:h, 0:w]
    row = iy // width
    offset = rng.integers(0, length, rows)[row]
    plank = (ix + offset) // length          # two planks per row per period
    plank_id = row * 2 + plank % 2
    tone = rng.uniform(0.8, 1.15, rows * 2)[plank_id]
    phase = rng.uniform(0, 2 * math.pi, rows * 2)[plank_id]
    wobble = _periodic_blur(rng.standard_normal((h, w)), 6.0)
    grain = 1.0 + 0.07 * np.sin(2 * math.pi * (iy % width) / 7.0
                                + 1.3 * wobble + phase)
    base = np.array([152.0, 102.0, 62.0])
    img = base * (tone * grain)[..., None]
    # dark joints: between rows and at plank ends
    joint = ((iy % width) == 0) | (((ix + offset) % length) == 0)
    img[joint] = (70.0, 45.0, 28.0)
    return texel, img


def _carpet(rng):
    # 2 mm texels, 0.512 m period: fibre noise plus soft blotches.
    texel, n = 0.002, 256
    fine = rng.standard_normal((n, n))
    blotch = _periodic_blur(rng.standard_normal((n, n)), 12.0)
    shade = 1.0 + 0.10 * fine + 0.05 * blotch
    tint = 1.0 + 0.03 * _periodic_blur(rng.standard_normal((n, n)), 3.0)
    base = np.array([118.0, 112.0, 104.0])
    img = base * shade[..., None]
    img[..., 2] *= tint
    return texel, img


def _tiles(rng):
    # 3 mm texels; 4 x 4 tiles of 30 cm per period, 6 mm grout.
    texel, tile, count = 0.003, 100, 4
    n = tile * count
    iy, ix = np.mgrid[0:n, 0:n]
    tone = rng.uniform(0.94, 1.05, (count, count))[iy // tile, ix // tile]
    speckle = 1.0 + 0.025 * rng.standard_normal((n, n))
    base = np.array([206.0, 200.0, 188.0])
    img = base * (tone * speckle)[..., None]
    grout = ((iy % tile) < 2) | ((ix % tile) < 2)
    img[grout] = (140.0, 136.0, 130.0)
    return texel, img


_GENERATORS = {"wood": _wood, "carpet": _carpet, "tiles": _tiles}


class FloorTexture:
    """A floor: a constant colour or a periodic texture with mip levels.

    Texel (iy, ix) of level 0 covers world y in [iy, iy + 1) * texel and
    x in [ix, ix + 1) * texel.
    """

    def __init__(self, name, seed=0):
        if name not in FLOORS:
            raise ValueError(f"unknown floor {name!r}, expected one of "
                             f"{', '.join(FLOORS)}")
        self.name = name
        self.description, plain = FLOORS[name]
        if plain is not None:
            self.plain = srgb8_to_linear(plain)
            self.srgb8 = np.array(plain, np.uint8).reshape(1, 1, 3)
            self.levels = None
        else:
            # A fixed stream per floor name, so floors do not depend on
            # which other floors the scene uses.
            rng = np.random.default_rng(
                [int(seed), 7001 + FLOOR_NAMES.index(name)])
            texel, img = _GENERATORS[name](rng)
            self.srgb8 = np.clip(np.rint(img), 0, 255).astype(np.uint8)
            self.plain = None
            self._build_levels(texel, srgb8_to_linear(self.srgb8))

    def _build_levels(self, texel, lin):
        # level: (image (h, w, 3) float32, texel size y, texel size x)
        levels = [(lin, texel, texel)]
        h0, w0 = lin.shape[:2]
        img = lin
        while img.shape[0] > 1 or img.shape[1] > 1:
            h, w = img.shape[:2]
            if h % 2 or w % 2:
                # odd size: go straight to the mean colour
                img = img.reshape(-1, 3).mean(axis=0).reshape(1, 1, 3)
            else:
                img = 0.25 * (img[0::2, 0::2] + img[1::2, 0::2]
                              + img[0::2, 1::2] + img[1::2, 1::2])
            h, w = img.shape[:2]
            levels.append((img.astype(np.float32), texel * h0 / h,
                           texel * w0 / w))
        self.levels = levels
        self.texel = texel

    def mean_lab(self):
        """Mean CIE L*a*b* of the floor's pixels (as palette learn would
        measure it on a sharp image)."""
        lab = reference.rgb_to_lab(self.srgb8)
        return lab.reshape(-1, 3).astype(np.float64).mean(axis=0)

    def mean_linear(self):
        if self.levels is None:
            return self.plain
        return self.levels[-1][0].reshape(3)

    def sample(self, x, y, footprint):
        """Linear RGB (N, 3) float32 at floor points, filtered over
        ``footprint`` metres (the pixel's size on the floor)."""
        n = x.shape[0]
        if self.levels is None:
            return np.broadcast_to(self.plain, (n, 3))
        top = len(self.levels) - 1
        with np.errstate(divide="ignore", invalid="ignore"):
            level = np.log2(np.maximum(footprint, 1e-9) / self.texel)
        level = np.clip(np.nan_to_num(level, nan=top, posinf=top), 0, top)
        low = np.minimum(level.astype(np.int32), top)
        frac = (level - low).astype(np.float32)
        out = np.empty((n, 3), np.float32)
        for lv in np.unique(low):
            sel = np.flatnonzero(low == lv)
            xs, ys = x[sel], y[sel]
            colour = self._bilinear(lv, xs, ys)
            if lv < top:
                f = frac[sel, None]
                # trilinear: blend with the next coarser level
                colour = (1 - f) * colour + f * self._bilinear(lv + 1, xs, ys)
            out[sel] = colour
        return out

    def _bilinear(self, lv, x, y):
        img, ty, tx = self.levels[lv]
        h, w = img.shape[:2]
        if h == 1 and w == 1:
            return np.broadcast_to(img.reshape(3), (x.shape[0], 3))
        fx = x / tx - 0.5
        fy = y / ty - 0.5
        x0 = np.floor(fx)
        y0 = np.floor(fy)
        wx = (fx - x0).astype(np.float32)[:, None]
        wy = (fy - y0).astype(np.float32)[:, None]
        x0 = x0.astype(np.int64) % w
        y0 = y0.astype(np.int64) % h
        x1 = (x0 + 1) % w
        y1 = (y0 + 1) % h
        flat = img.reshape(-1, 3)
        top = flat[y0 * w + x0] * (1 - wx) + flat[y0 * w + x1] * wx
        bottom = flat[y1 * w + x0] * (1 - wx) + flat[y1 * w + x1] * wx
        return top * (1 - wy) + bottom * wy
