"""Exact ray casting of the synthetic world, vectorised with numpy.

Each frame is traced in two passes:

1. one ray per pixel centre against the floor, the walls and the sky;
2. ``supersample`` x ``supersample`` rays in every pixel that may hold an
   object (the projected bounding box of each landmark and distractor) or
   a floor / wall / sky boundary; those rays are also tested against the
   objects.  Coverage, centroids and the class mask come from them.

Colours are averaged in linear light; exposure, white balance and
vignetting act on linear light; then sRGB encoding and sensor noise.
"""

import math

import numpy as np

from .camera import Pose, ground_coordinates
from .floors import linear_to_srgb, srgb8_to_linear
from .freespace import circle_edges, free_ranges

SKY, FLOOR, WALL = 0, 1, 2
OBJ0 = 3                      # surface id of object k is OBJ0 + k
# then obstacle j: OBJ0 + (number of objects) + j
FLOOR_TRUTH_BINS = 360        # bearing bins of the free-floor truth
NEAR = 1e-3                   # metres: the near clipping plane
OUTLINE_POINTS = 48
CUT_POINTS = 96
# An object counts as occluded when this much of its area is hidden.
OCCLUDED_MIN_PIXELS = 0.1
# Direction towards the light, world frame (from above, a little ahead).
LIGHT = np.array([0.35, 0.25, 0.9]) / np.linalg.norm([0.35, 0.25, 0.9])
AUTO_TARGET = 0.18            # grey-world auto exposure target (linear)
LUT_SIZE = 16384


class _Object:
    """A landmark or distractor prepared for tracing; a coded marker is
    one object per band (``band``: its index, top first)."""

    def __init__(self, index, kind, cls_value, colour, x, y, z, radius,
                 verts, present, landmark=None, band=None):
        self.index = index
        self.kind = kind          # "disc", "poly", "ball", "cyl" or "cone"
        self.cls_value = cls_value
        self.colour = colour
        self.x, self.y, self.z = x, y, z
        self.radius = radius
        self.verts = verts        # (N, 2) for polygons
        self.present = present
        self.landmark = landmark
        self.band = band
        if band is not None:
            # the band's slice [z0, z1] of the marker standing on z; a
            # cone's radius falls from `radius` at its base to 0 at its top
            lm = landmark
            self.base, self.height = lm.z, lm.height
            top = lm.z + lm.height - sum(lm.band_heights[:band])
            self.z0, self.z1 = top - lm.band_heights[band], top

    @property
    def flat(self):
        return self.kind in ("disc", "poly")

    @property
    def upright(self):
        return self.kind in ("cyl", "cone")

    def radius_at(self, z):
        """The upright marker's radius at height z."""
        if self.kind == "cyl":
            return self.radius
        return self.radius * (self.base + self.height - z) / self.height

    @property
    def centre(self):
        return np.array([self.x, self.y, self.z])


def _clip_near(points):
    """Clip a closed polygon (camera coordinates) to z >= NEAR."""
    out = []
    n = len(points)
    for i in range(n):
        a, b = points[i], points[(i + 1) % n]
        in_a, in_b = a[2] >= NEAR, b[2] >= NEAR
        if in_a:
            out.append(a)
        if in_a != in_b:
            f = (NEAR - a[2]) / (b[2] - a[2])
            out.append(a + f * (b - a))
    return np.array(out).reshape(-1, 3)


def _circle(centre, e1, e2, radius, count):
    a = np.linspace(0.0, 2.0 * math.pi, count, endpoint=False)
    return (centre[None, :] + radius * (np.cos(a)[:, None] * e1[None, :]
                                        + np.sin(a)[:, None] * e2[None, :]))


class Renderer:
    """Per-scene precomputed state; ``render`` draws one frame."""

    def __init__(self, scene):
        self.scene = scene
        cam = self.camera = scene.camera
        w, h = cam.width, cam.height
        vv, uu = np.mgrid[0:h, 0:w]
        self.u_pix = uu.ravel().astype(np.float64)
        self.v_pix = vv.ravel().astype(np.float64)
        self.pix_dirs = cam.pixel_directions(self.u_pix, self.v_pix) \
            .astype(np.float32)
        s = self.ss = int(scene.supersample)
        offsets = (np.arange(s) + 0.5) / s - 0.5
        dv, du = np.meshgrid(offsets, offsets, indexing="ij")
        self.sub_du, self.sub_dv = du.ravel(), dv.ravel()

        palette = self.palette = scene.scene_palette()
        names = palette.names
        self.n_classes = len(names)
        srgb = scene.marker_srgb8()
        objects = []
        # each landmark's objects: one, or a coded marker's bands
        self.marker_objects = []
        for lm in scene.landmarks:
            first = len(objects)
            if lm.coded:
                kind = "cone" if lm.kind == "cone" else "cyl"
                for k, cls in enumerate(lm.bands):
                    objects.append(_Object(
                        len(objects), kind, names.index(cls) + 1,
                        srgb8_to_linear(srgb[cls]), lm.x, lm.y, lm.z,
                        lm.radius, None, lm.present, landmark=lm, band=k))
            else:
                objects.append(_Object(
                    len(objects), lm.kind, names.index(lm.cls) + 1,
                    srgb8_to_linear(srgb[lm.cls]), lm.x, lm.y, lm.z,
                    lm.radius, None, lm.present, landmark=lm))
            self.marker_objects.append(objects[first:])
        self.n_landmarks = len(objects)
        for d in scene.distractors:
            verts = d.polygon()
            objects.append(_Object(
                len(objects), "poly" if verts is not None else "disc",
                names.index(d.cls) + 1, srgb8_to_linear(srgb[d.cls]),
                d.x, d.y, 0.0, d.size / 2.0, verts, d.present))
        self.objects = objects
        self.has_upright = any(o.upright for o in objects)
        # Flat things on the floor: distractors under landmark discs; balls
        # after them (depth-tested).
        self.draw_order = (
            [o for o in objects[self.n_landmarks:] if o.flat]
            + [o for o in objects[:self.n_landmarks] if o.flat]
            + [o for o in objects if not o.flat])

        self.obstacle0 = OBJ0 + len(objects)
        n_ids = self.obstacle0 + len(scene.obstacles)
        self.colours = np.zeros((n_ids, 3), np.float32)
        self.colours[SKY] = srgb8_to_linear(scene.sky_colour)
        self.class_of = np.zeros(n_ids, np.int32)
        if scene.walls is not None:
            self.colours[WALL] = srgb8_to_linear(scene.walls.colour)
            self.class_of[WALL] = names.index("wall") + 1
        for o in objects:
            self.colours[OBJ0 + o.index] = o.colour
            self.class_of[OBJ0 + o.index] = o.cls_value
        for j, ob in enumerate(scene.obstacles):
            self.colours[self.obstacle0 + j] = srgb8_to_linear(ob.colour)
            self.class_of[self.obstacle0 + j] = names.index(
                scene.obstacle_class_name(ob.colour)) + 1
        self.floor_segments = scene.floor_segments()
        self.floor_value = {
            name: names.index(scene.floor_class_name(name)) + 1
            for name in scene.floor_names()}
        self.is_ball = np.zeros(n_ids, bool)
        self.is_upright = np.zeros(n_ids, bool)
        self.centres = np.zeros((n_ids, 3), np.float32)
        self.radii = np.ones(n_ids, np.float32)
        for o in objects:
            self.is_ball[OBJ0 + o.index] = o.kind == "ball"
            self.is_upright[OBJ0 + o.index] = o.upright
            self.centres[OBJ0 + o.index] = o.centre
            self.radii[OBJ0 + o.index] = o.radius

        if scene.effects.vignette:
            r2 = (((self.u_pix - cam.cx) ** 2 + (self.v_pix - cam.cy) ** 2)
                  / (cam.cx ** 2 + cam.cy ** 2))
            self.vignette = (1.0 - scene.effects.vignette * r2) \
                .astype(np.float32)[:, None]
        else:
            self.vignette = None
        self.lut = (linear_to_srgb(np.linspace(0.0, 1.0, LUT_SIZE))
                    * 255.0).astype(np.float32)
        if scene.light is None:
            self.light = LIGHT.astype(np.float32)
        else:
            light = np.asarray(scene.light, np.float64)
            norm = np.linalg.norm(light)
            if light.shape != (3,) or not np.isfinite(norm) or norm <= 0:
                raise ValueError(f"light direction must be a non-zero "
                                 f"3-vector, got {scene.light}")
            self.light = (light / norm).astype(np.float32)

    # -- geometry -----------------------------------------------------------

    def _static_hits(self, dirs, centre):
        """Floor, walls and sky: (t_floor, surface id, t of the surface)."""
        cz = np.float32(centre[2])
        dz = dirs[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            t_floor = np.where(dz < 0, -cz / dz, np.inf).astype(np.float32)
        ids = np.where(np.isfinite(t_floor), FLOOR, SKY).astype(np.int32)
        t_cur = t_floor.copy()
        for j, ob in enumerate(self.scene.obstacles):
            t = self._box_hit(ob, dirs, centre)
            ok = t < t_cur
            t_cur = np.where(ok, t, t_cur)
            ids[ok] = self.obstacle0 + j
        walls = self.scene.walls
        if walls is None:
            return t_floor, ids, t_cur
        planes = ((0, walls.x0, walls.y0, walls.y1),
                  (0, walls.x1, walls.y0, walls.y1),
                  (1, walls.y0, walls.x0, walls.x1),
                  (1, walls.y1, walls.x0, walls.x1))
        for axis, value, lo, hi in planes:
            other = 1 - axis
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (np.float32(value - centre[axis])) / dirs[:, axis]
            ok = (t > 0) & (t < t_cur)
            z = cz + t * dz
            o = np.float32(centre[other]) + t * dirs[:, other]
            ok &= (z >= 0) & (z <= walls.height) & (o >= lo) & (o <= hi)
            t_cur = np.where(ok, t, t_cur)
            ids[ok] = WALL
        return t_floor, ids, t_cur

    @staticmethod
    def _box_hit(ob, dirs, centre):
        """Where rays from centre first meet a box standing on the floor
        (slabs in the box's own axes); inf where they miss it."""
        c, s = math.cos(ob.angle), math.sin(ob.angle)
        ox, oy = centre[0] - ob.x, centre[1] - ob.y
        o = np.array([c * ox + s * oy, -s * ox + c * oy, centre[2]],
                     np.float32)
        d = np.stack([c * dirs[:, 0] + s * dirs[:, 1],
                      -s * dirs[:, 0] + c * dirs[:, 1], dirs[:, 2]], 1)
        lo = np.array([-ob.size_x / 2, -ob.size_y / 2, 0.0], np.float32)
        hi = np.array([ob.size_x / 2, ob.size_y / 2, ob.height], np.float32)
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (lo - o) / d
            t2 = (hi - o) / d
        near = np.nanmax(np.minimum(t1, t2), axis=1)
        far = np.nanmin(np.maximum(t1, t2), axis=1)
        hit = (near <= far) & (near > 0)
        return np.where(hit, near, np.inf).astype(np.float32)

    @staticmethod
    def _upright_hit(o, dirs, centre):
        """Where rays from centre enter the upright marker that band ``o``
        belongs to: (t, z, outward normal) of the entry, t = inf where they
        miss it.  The side is the first crossing of the cylinder (or the
        cone's lower sheet) between the base and the top; a cap is entered
        only from the side it faces."""
        d = dirs.astype(np.float64)
        dx, dy, dz = d[:, 0], d[:, 1], d[:, 2]
        wx, wy, cz = centre[0] - o.x, centre[1] - o.y, float(centre[2])
        base, top = o.base, o.base + o.height
        n = len(d)
        t = np.full(n, np.inf)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if o.kind == "cyl":
                a = dx * dx + dy * dy
                b = 2.0 * (wx * dx + wy * dy)
                c = wx * wx + wy * wy - o.radius ** 2
                disc = b * b - 4.0 * a * c
                roots = [(-b - np.sqrt(np.maximum(disc, 0))) / (2.0 * a)]
            else:
                k2 = (o.radius / o.height) ** 2
                wz = cz - top
                a = dx * dx + dy * dy - k2 * dz * dz
                b = 2.0 * (wx * dx + wy * dy - k2 * wz * dz)
                c = wx * wx + wy * wy - k2 * wz * wz
                disc = b * b - 4.0 * a * c
                # the two roots without cancellation
                q = -0.5 * (b + np.copysign(np.sqrt(np.maximum(disc, 0)), b))
                t1, t2 = q / a, c / q
                roots = [np.fmin(t1, t2), np.fmax(t1, t2)]
            for root in roots:
                z = cz + root * dz
                ok = ((disc >= 0) & (root > 0) & (z >= base) & (z <= top)
                      & (root < t))
                t = np.where(ok, root, t)
            side = np.isfinite(t)
            caps = []
            if cz > top and o.kind == "cyl":
                caps.append((top, 1.0))
            if cz < base:
                caps.append((base, -1.0))
            cap_sign = np.zeros(n)
            for zc, sign in caps:
                tc = (zc - cz) / dz
                px, py = wx + tc * dx, wy + tc * dy
                ok = ((tc > 0) & (px * px + py * py
                                  <= o.radius_at(zc) ** 2) & (tc < t))
                t = np.where(ok, tc, t)
                cap_sign = np.where(ok, sign, cap_sign)
                side &= ~ok
            z = cz + t * dz
            px, py = wx + t * dx, wy + t * dy
            rho = np.hypot(px, py)
            normal = np.zeros((n, 3))
            if o.kind == "cyl":
                normal[:, 0], normal[:, 1] = px / rho, py / rho
            else:
                slant = math.hypot(o.height, o.radius)
                normal[:, 0] = px / rho * (o.height / slant)
                normal[:, 1] = py / rho * (o.height / slant)
                normal[:, 2] = o.radius / slant
            normal[~side] = 0.0
            normal[:, 2] += cap_sign
        return t, z, normal

    def _outline(self, o, centre, count, circumscribed):
        """World points bounding the object's image: a polygon around the
        disc, the polygon itself, or the ball's silhouette circle.  None if
        the camera is inside a ball."""
        grow = 1.0 / math.cos(math.pi / count) if circumscribed else 1.0
        if o.upright:
            return self._upright_outline(o, o.z0, o.z1, count, grow)
        if o.kind == "poly":
            return np.column_stack([o.verts, np.zeros(len(o.verts))])
        if o.kind == "disc":
            return _circle(o.centre, np.array([1.0, 0, 0]),
                           np.array([0, 1.0, 0]), o.radius * grow, count)
        v = o.centre - centre
        dist = np.linalg.norm(v)
        if dist <= o.radius * 1.0001:
            return None
        n = v / dist
        e1 = np.cross(n, [0.0, 0.0, 1.0])
        if np.linalg.norm(e1) < 1e-9:
            e1 = np.cross(n, [1.0, 0.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        rho = o.radius * math.sqrt(1.0 - (o.radius / dist) ** 2)
        q = o.centre - (o.radius ** 2 / dist) * n
        return _circle(q, e1, e2, rho * grow, count)

    @staticmethod
    def _upright_outline(o, z0, z1, count, grow=1.0):
        """The circles at z0 and z1 of an upright marker (radius grown by
        ``grow``), (2 count, 3): the corners of the prism around that slice
        of it, bottom then top."""
        e1, e2 = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
        return np.concatenate([
            _circle(np.array([o.x, o.y, z]), e1, e2,
                    o.radius_at(z) * grow, count) for z in (z0, z1)])

    @staticmethod
    def _clip_prism(pc, count):
        """The corners of the prism ``pc`` (camera coordinates, two rings
        of ``count``) in front of the near plane, with the points where its
        edges cross it: the corners of the clipped prism, whose image is
        the convex hull of theirs."""
        ring = np.arange(count)
        edges = np.concatenate([
            np.stack([ring, (ring + 1) % count], 1),
            np.stack([ring, (ring + 1) % count], 1) + count,
            np.stack([ring, ring + count], 1)])
        a, b = pc[edges[:, 0]], pc[edges[:, 1]]
        out = [pc[pc[:, 2] >= NEAR]]
        cross = (a[:, 2] >= NEAR) != (b[:, 2] >= NEAR)
        if cross.any():
            a, b = a[cross], b[cross]
            f = (NEAR - a[:, 2]) / (b[:, 2] - a[:, 2])
            out.append(a + f[:, None] * (b - a))
        return np.concatenate(out)

    def _bbox(self, o, rot, centre):
        """Inclusive pixel box (u0, u1, v0, v1) where the object may be
        seen, or None."""
        cam = self.camera
        w, h = cam.width, cam.height
        if o.upright:
            pc = (self._outline(o, centre, OUTLINE_POINTS, True) - centre) \
                @ rot.T
            pc = self._clip_prism(pc, OUTLINE_POINTS)
            if len(pc) == 0:
                return None
            return self._pixel_box(pc)
        if o.kind == "ball":
            zc = (o.centre - centre) @ rot[2]
            if zc + o.radius <= NEAR:
                return None
        # A ball's image is that of the disc its silhouette circle bounds;
        # the part of that disc in front of the camera stays convex.
        pts = self._outline(o, centre, OUTLINE_POINTS, True)
        if pts is None:
            return (0, w - 1, 0, h - 1)     # the camera is inside a ball
        pc = (pts - centre) @ rot.T
        if (pc[:, 2] < NEAR).any():
            pc = _clip_near(pc)
            if len(pc) == 0:
                return None
        return self._pixel_box(pc)

    def _pixel_box(self, pc):
        """Inclusive pixel box (u0, u1, v0, v1) around camera points in
        front of the near plane, or None outside the image."""
        cam = self.camera
        w, h = cam.width, cam.height
        u = cam.fx * pc[:, 0] / pc[:, 2] + cam.cx
        v = cam.fy * pc[:, 1] / pc[:, 2] + cam.cy
        # the sub-samples of a pixel reach half a pixel beyond its centre
        u0 = max(int(math.floor(u.min() - 1.0)), 0)
        u1 = min(int(math.ceil(u.max() + 1.0)), w - 1)
        v0 = max(int(math.floor(v.min() - 1.0)), 0)
        v1 = min(int(math.ceil(v.max() + 1.0)), h - 1)
        if u0 > u1 or v0 > v1:
            return None
        return (u0, u1, v0, v1)

    def is_cut(self, o, rot, centre):
        """Whether the image border cuts the object's outline (or part of
        it lies behind the camera); of a band, the whole marker's."""
        cam = self.camera
        if o.upright:
            lm = o.landmark
            pts = self._upright_outline(o, lm.z, lm.z + lm.height,
                                        CUT_POINTS)
        else:
            pts = self._outline(o, centre, CUT_POINTS, False)
        if pts is None:
            return True
        pc = (pts - centre) @ rot.T
        if (pc[:, 2] < NEAR).any():
            return True
        if o.kind == "ball":
            zc = (o.centre - centre) @ rot[2]
            if zc - o.radius < NEAR:
                return True
        u = cam.fx * pc[:, 0] / pc[:, 2] + cam.cx
        v = cam.fy * pc[:, 1] / pc[:, 2] + cam.cy
        return bool((u < -0.5).any() or (u > cam.width - 0.5).any()
                    or (v < -0.5).any() or (v > cam.height - 0.5).any())

    def _floor_colour(self, floor, dirs, t_floor, centre, scale):
        """Texture colour at the floor hit of each ray; ``scale`` divides
        the pixel footprint (the sub-pixel sample spacing)."""
        x = np.float32(centre[0]) + t_floor * dirs[:, 0]
        y = np.float32(centre[1]) + t_floor * dirs[:, 1]
        if floor.levels is None:
            return np.broadcast_to(floor.plain, (len(x), 3))
        # pixel area on the floor is t^2 / (f^2 |dz|) for these directions
        footprint = t_floor / (self.camera.fx * scale
                               * np.sqrt(np.abs(dirs[:, 2])))
        return floor.sample(x, y, footprint)

    def trace(self, pose, floor, frame=None):
        """Linear RGB (H*W, 3) and the geometry facts of one instant."""
        cam = self.camera
        w, h = cam.width, cam.height
        rot, centre = cam.world_to_camera(pose)
        # row vectors: world direction = camera direction @ R_wc
        rot32 = rot.astype(np.float32)
        dirs = self.pix_dirs @ rot32
        t_floor, ids, t_cur = self._static_hits(dirs, centre)

        # pixels needing supersampling: surface boundaries...
        grid = ids.reshape(h, w)
        need = np.zeros((h, w), bool)
        for a, b in (((slice(None), slice(1, None)),
                      (slice(None), slice(None, -1))),
                     ((slice(1, None), slice(None)),
                      (slice(None, -1), slice(None))),
                     ((slice(1, None), slice(1, None)),
                      (slice(None, -1), slice(None, -1))),
                     ((slice(1, None), slice(None, -1)),
                      (slice(None, -1), slice(1, None)))):
            diff = grid[a] != grid[b]
            need[a] |= diff
            need[b] |= diff
        # ...and every pixel an object may touch
        boxes = {}
        for o in self.objects:
            if not o.present(frame):
                continue
            box = self._bbox(o, rot, centre)
            if box is not None:
                boxes[o.index] = box
                u0, u1, v0, v1 = box
                need[v0:v1 + 1, u0:u1 + 1] = True

        cidx = np.flatnonzero(need.ravel())
        simple = np.ones(h * w, bool)
        simple[cidx] = False
        lin = np.empty((h * w, 3), np.float32)
        floor_value = self.floor_value[floor.name]
        mask = self.class_of[ids].astype(np.uint8)
        mask[ids == FLOOR] = floor_value
        # one sample per pixel where nothing changes within the pixel
        lin[simple] = self.colours[ids[simple]]
        on_floor = np.flatnonzero(simple & (ids == FLOOR))
        lin[on_floor] = self._floor_colour(floor, dirs[on_floor],
                                           t_floor[on_floor], centre, 1.0)

        n_obj = len(self.objects)
        geo = {"rot": rot, "centre": centre, "boxes": boxes,
               "coverage": np.zeros(n_obj), "sum_u": np.zeros(n_obj),
               "sum_v": np.zeros(n_obj), "hidden": np.zeros(n_obj),
               "band_box": {}, "pure": np.ones(h * w, bool)}
        if len(cidx):
            self._trace_samples(cidx, rot32, centre, floor, floor_value,
                                boxes, lin, mask, geo)
        geo["mask"] = mask.reshape(h, w)
        geo["pure"] = geo["pure"].reshape(h, w)
        return lin, geo

    def _trace_samples(self, cidx, rot32, centre, floor, floor_value, boxes,
                       lin, mask, geo):
        cam = self.camera
        w, h = cam.width, cam.height
        ss2 = self.ss * self.ss
        n_c = len(cidx)
        pix_index = np.full(h * w, -1, np.int64)
        pix_index[cidx] = np.arange(n_c)
        pix_index = pix_index.reshape(h, w)
        su = (self.u_pix[cidx][:, None] + self.sub_du[None, :]).ravel()
        sv = (self.v_pix[cidx][:, None] + self.sub_dv[None, :]).ravel()
        sdirs = cam.pixel_directions(su, sv).astype(np.float32) @ rot32
        s_floor, sids, s_cur = self._static_hits(sdirs, centre)
        cx, cy, cz = (np.float32(c) for c in centre)
        with np.errstate(invalid="ignore"):
            sx = cx + s_floor * sdirs[:, 0]
            sy = cy + s_floor * sdirs[:, 1]
        sub = np.arange(ss2)
        records = []
        # outward normals where an upright marker is hit (its shading)
        normals = np.zeros((len(sids), 3), np.float32) \
            if self.has_upright else None
        for o in self.draw_order:
            box = boxes.get(o.index)
            if box is None:
                continue
            u0, u1, v0, v1 = box
            si = (pix_index[v0:v1 + 1, u0:u1 + 1].reshape(-1, 1) * ss2
                  + sub).ravel()
            with np.errstate(divide="ignore", invalid="ignore"):
                if o.upright:
                    t, z, normal = self._upright_hit(o, sdirs[si], centre)
                    # the entry belongs to the band whose slice holds it
                    raw = np.isfinite(t) & (z >= o.z0) & (z <= o.z1)
                    t = t.astype(np.float32)
                    hit = raw & (t < s_cur[si])
                    normals[si[hit]] = normal[hit]
                elif o.kind == "ball":
                    d = sdirs[si]
                    oc = (centre - o.centre).astype(np.float32)
                    a = np.einsum("ij,ij->i", d, d)
                    b = 2.0 * (d @ oc)
                    c = np.float32(oc @ oc - o.radius ** 2)
                    disc = b * b - 4.0 * a * c
                    t = (-b - np.sqrt(np.maximum(disc, 0))) / (2.0 * a)
                    raw = (disc >= 0) & (t > 0)
                    hit = raw & (t < s_cur[si])
                else:
                    if o.z == 0.0:
                        t, x, y = s_floor[si], sx[si], sy[si]
                    else:
                        d = sdirs[si]
                        t = (np.float32(o.z) - cz) / d[:, 2]
                        t = np.where(t > 0, t, np.inf).astype(np.float32)
                        x, y = cx + t * d[:, 0], cy + t * d[:, 1]
                    if o.kind == "disc":
                        inside = ((x - np.float32(o.x)) ** 2
                                  + (y - np.float32(o.y)) ** 2
                                  <= np.float32(o.radius ** 2))
                    else:
                        inside = np.isfinite(x)
                        verts = o.verts
                        for i in range(len(verts)):
                            ax, ay = verts[i]
                            bx, by = verts[(i + 1) % len(verts)]
                            inside &= ((bx - ax) * (y - ay)
                                       - (by - ay) * (x - ax)) >= 0
                    raw = inside & np.isfinite(t)
                    # equal depth: later flat objects lie on top
                    hit = raw & (t <= s_cur[si])
            hit_si = si[hit]
            sids[hit_si] = OBJ0 + o.index
            s_cur[hit_si] = t[hit]
            records.append((o.index, si[raw]))

        # colours of the samples
        scol = self.colours[sids]
        fl = np.flatnonzero(sids == FLOOR)
        scol[fl] = self._floor_colour(floor, sdirs[fl], s_floor[fl], centre,
                                      float(self.ss))
        balls = np.flatnonzero(self.is_ball[sids])
        k = self.scene.effects.ball_shading
        if len(balls) and k:
            p = (centre.astype(np.float32)
                 + s_cur[balls, None] * sdirs[balls])
            normal = (p - self.centres[sids[balls]]) \
                / self.radii[sids[balls], None]
            lam = np.clip(normal @ self.light, 0.0, 1.0)
            scol[balls] *= (1.0 - k + k * lam)[:, None]
        if normals is not None and k:
            # lit as the balls are: Lambert on the surface's normal
            up = np.flatnonzero(self.is_upright[sids])
            lam = np.clip(normals[up] @ self.light, 0.0, 1.0)
            scol[up] *= (1.0 - k + k * lam)[:, None]
        lin[cidx] = scol.reshape(n_c, ss2, 3).mean(axis=1)

        # majority class per supersampled pixel
        cls = self.class_of[sids]
        cls[sids == FLOOR] = floor_value
        k1 = self.n_classes + 1
        pix = np.repeat(np.arange(n_c), ss2)
        counts = np.bincount(pix * k1 + cls, minlength=n_c * k1) \
            .reshape(n_c, k1)
        mask[cidx] = counts.argmax(axis=1)
        # a pixel is pure when all its samples are of one class
        geo["pure"][cidx] = counts.max(axis=1) == ss2

        # coverage and centroids per object, from visible samples
        on_obj = np.flatnonzero((sids >= OBJ0) & (sids < self.obstacle0))
        n_obj = len(self.objects)
        kk = sids[on_obj] - OBJ0
        p = cidx[on_obj // ss2]
        geo["coverage"] = np.bincount(kk, minlength=n_obj) / ss2
        geo["sum_u"] = np.bincount(kk, self.u_pix[p], minlength=n_obj) / ss2
        geo["sum_v"] = np.bincount(kk, self.v_pix[p], minlength=n_obj) / ss2
        for index, raw_si in records:
            geo["hidden"][index] = np.count_nonzero(
                sids[raw_si] != OBJ0 + index) / ss2
        if self.has_upright:
            # each band's image box: its visible samples' extent, out by
            # half a sample spacing (within 1 / (2 ss) px of the edge)
            half = 0.5 / self.ss
            for o in self.objects[:self.n_landmarks]:
                mine = on_obj[kk == o.index] if o.upright else ()
                if len(mine):
                    geo["band_box"][o.index] = (
                        float(su[mine].min() - half),
                        float(sv[mine].min() - half),
                        float(su[mine].max() + half),
                        float(sv[mine].max() + half))

    # -- frames -------------------------------------------------------------

    def render(self, pose, t=None, frame=None, frames_total=None):
        """(rgb uint8 (H, W, 3), truth dict, class mask uint8 (H, W))."""
        scene = self.scene
        if t is None:
            t = (frame or 0) / scene.fps
        floor_name, seg_stops, seg_wb = scene.segment_state(frame,
                                                            frames_total)
        lin, geo = self.linear(pose, t, frame,
                               scene.floor_texture(floor_name))
        gains = self.gains(lin, t, seg_stops, seg_wb)
        rgb = self.finish(lin, gains, frame)
        truth = self._truth(pose, geo, frame, t)
        return rgb, truth, geo["mask"]

    def linear(self, pose, t, frame, floor):
        """Linear RGB (H*W, 3) of one frame (motion blur averaged) and
        the geometry facts of its instant."""
        scene = self.scene
        eff = scene.effects
        blur = int(eff.motion_blur or 0)
        if blur <= 1 or scene.trajectory is None:
            return self.trace(pose, floor, frame)
        offsets = ((np.arange(blur) + 0.5) / blur - 0.5) \
            * eff.shutter / scene.fps
        acc = None
        geo = None
        for dt in offsets:
            sub_pose = (pose if abs(dt) < 1e-12
                        else scene.trajectory.pose(t + dt))
            lin, g = self.trace(sub_pose, floor, frame)
            acc = lin if acc is None else acc + lin
            if abs(dt) < 1e-12:
                geo = g
        if geo is None:
            # truth is of the frame's instant, not of a sub-frame
            _, geo = self.trace(pose, floor, frame)
        return acc / blur, geo

    def gains(self, lin, t, seg_stops, seg_wb):
        """Red, green and blue gains on linear light at time ``t``:
        exposure, white balance and their drifts, then auto exposure and
        white balance measured on ``lin``."""
        eff = self.scene.effects
        phase = 2.0 * math.pi * t / eff.drift_period_s \
            if eff.drift_period_s else 0.0
        stops = (eff.exposure_stops + seg_stops
                 + eff.exposure_drift_stops * math.sin(phase))
        drift = eff.wb_drift * math.sin(phase + 1.0)
        gains = (2.0 ** stops) * np.array(
            [seg_wb[0] * (1.0 + drift), 1.0, seg_wb[1] * (1.0 - drift)])
        if eff.auto_exposure or eff.auto_wb:
            # grey world on a subsample: fast and plenty accurate
            mean = lin[::7].mean(axis=0).astype(np.float64) * gains
            luma = float(mean @ [0.2126, 0.7152, 0.0722])
            if luma > 1e-6:
                gains *= (AUTO_TARGET / luma) ** eff.auto_exposure
                gains *= (luma / np.maximum(mean, 1e-6)) ** eff.auto_wb
        return gains

    def finish(self, lin, gains, frame):
        """sRGB uint8 image from linear light: gains, vignetting, sRGB
        encoding, then the frame's sensor noise."""
        scene = self.scene
        eff = scene.effects
        cam = self.camera
        img = lin * gains.astype(np.float32)
        if self.vignette is not None:
            img *= self.vignette
        index = np.clip(img * (LUT_SIZE - 1) + 0.5, 0, LUT_SIZE - 1)
        out = self.lut[index.astype(np.int32)]
        if eff.noise_sigma:
            rng = np.random.default_rng(
                [int(scene.seed), int(frame or 0), 99])
            out += rng.standard_normal(out.shape, np.float32) \
                * np.float32(eff.noise_sigma)
        rgb = np.clip(np.rint(out), 0, 255).astype(np.uint8)
        return rgb.reshape(cam.height, cam.width, 3)

    def _image_point(self, name, point, pose):
        """{"u_NAME", "v_NAME"}: the projection of a world point, null
        behind the camera."""
        uv, _ = self.camera.project(np.asarray(point)[None, :], pose)
        u, v = (None if not np.isfinite(x) else round(float(x), 4)
                for x in uv[0])
        return {f"u_{name}": u, f"v_{name}": v}

    def _coded_truth(self, lm, objs, geo, pose):
        """A coded marker's own truth: its code, its and each band's image
        box of visible pixels, and the image of its floor contact: the
        foot of its axis (``base``) and the base's point nearest the
        camera (``front``, the lowest point of its outline there)."""
        boxes = [geo["band_box"].get(o.index) for o in objs]
        out = {"code": lm.cls, "box": _rounded_box(_union_box(boxes)),
               "bands": [{"class": cls, "box": _rounded_box(box),
                          "pixels": round(float(geo["coverage"][o.index]),
                                          4)}
                         for cls, box, o in zip(lm.bands, boxes, objs)]}
        out.update(self._image_point("base", (lm.x, lm.y, lm.z), pose))
        away = np.array([lm.x - pose.x, lm.y - pose.y])
        dist = float(np.hypot(*away))
        if dist > lm.radius:
            fx, fy = np.array([lm.x, lm.y]) - lm.radius * away / dist
            out.update(self._image_point("front", (fx, fy, lm.z), pose))
        else:
            out.update({"u_front": None, "v_front": None})
        return out

    def _truth(self, pose, geo, frame, t):
        out = {}
        if frame is not None:
            out["frame"] = int(frame)
            out["pts"] = int(frame) * 1_000_000_000 // int(self.scene.fps)
        out["robot"] = pose.to_json()
        lms = []
        for objs in self.marker_objects:
            cov = sum(geo["coverage"][o.index] for o in objs)
            if cov <= 0 or not any(o.index in geo["boxes"] for o in objs):
                continue
            lm = objs[0].landmark
            hidden = sum(geo["hidden"][o.index] for o in objs)
            centre = (np.array([lm.x, lm.y, lm.z + lm.height / 2.0])
                      if lm.coded else objs[0].centre)
            gx, gy, rng, bearing = ground_coordinates(pose, lm.x, lm.y)
            mark = {
                "id": lm.id, "class": lm.cls, "kind": lm.kind,
                "u": round(float(sum(geo["sum_u"][o.index]
                                     for o in objs) / cov), 4),
                "v": round(float(sum(geo["sum_v"][o.index]
                                     for o in objs) / cov), 4)}
            mark.update(self._image_point("centre", centre, pose))
            mark.update({
                "pixels": round(float(cov), 4),
                "range": round(rng, 7), "bearing": round(bearing, 7),
                "ground_x": round(gx, 7), "ground_y": round(gy, 7),
                "cut": self.is_cut(objs[0], geo["rot"], geo["centre"]),
                "occluded": bool(hidden >= OCCLUDED_MIN_PIXELS),
                # hidden share of the pixels it would cover unoccluded
                "occluded_fraction": round(float(hidden / (cov + hidden)),
                                           4),
            })
            if lm.coded:
                mark.update(self._coded_truth(lm, objs, geo, pose))
            lms.append(mark)
        out["landmarks"] = lms
        if self.scene.obstacles:
            # the free floor per bearing bin from the camera's floor point
            # (floorboundary's bins): the nearest wall, obstacle or ball
            # (the robot must not hit one) in the bin, null when nothing
            # ends the floor there
            segs = [self.floor_segments] + [
                circle_edges(o.x, o.y, o.radius)
                for o in self.objects[:self.n_landmarks]
                if (o.kind == "ball" or o.band == 0) and o.present(frame)]
            free = free_ranges(pose.x, pose.y, pose.heading,
                               np.concatenate(segs), FLOOR_TRUTH_BINS)
            out["floor"] = {
                "bearing-bins": FLOOR_TRUTH_BINS,
                "free-range": [round(float(r), 5) if np.isfinite(r)
                               else None for r in free]}
        return out


def _rounded_box(box):
    return [round(v, 4) for v in box] if box is not None else None


def _union_box(boxes):
    boxes = [b for b in boxes if b is not None]
    if not boxes:
        return None
    return (min(b[0] for b in boxes), min(b[1] for b in boxes),
            max(b[2] for b in boxes), max(b[3] for b in boxes))


def renderer(scene):
    """The scene's cached Renderer."""
    key = ("renderer",)
    if key not in scene._cache:
        scene._cache[key] = Renderer(scene)
    return scene._cache[key]


def render_frame(scene, pose, t=None, frame=None, frames_total=None):
    """Render one frame: (rgb uint8 (H, W, 3), truth dict, class mask
    uint8 (H, W)).  ``pose`` is a Pose or (x, y, heading); ``t`` seconds
    (default frame / fps); ``frame`` selects per-frame content (landmarks
    present, floor schedule, noise)."""
    if not isinstance(pose, Pose):
        pose = Pose(*pose)
    return renderer(scene).render(pose, t=t, frame=frame,
                                  frames_total=frames_total)
