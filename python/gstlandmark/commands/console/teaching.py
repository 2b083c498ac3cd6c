"""Palette teaching from the page: boxes drawn on frozen frames learned
as ``palette learn --rect`` does, classes edited, undo; each new palette
written for labsegment to read on its next frame."""

from __future__ import annotations

import dataclasses
import json
import os
from typing import Any, Callable, Dict, List, Optional, Tuple

import cv2
import numpy as np

from ... import palette as pal, paletteaudit, pipeline
from ... import reference
from .livefiles import LiveFiles
from .values import ConsoleError, check_box, is_number

Gst = pipeline.Gst

UNDO_DEPTH = 20
FROZEN_KEPT = 4         # frozen teaching frames kept (one per browser)
# what ``palette learn`` does by default, so both give one palette
TEACH_REFERENCES = "auto"
UNTAUGHT_CLASS = "untaught"
MAX_TOLERANCE = 64.0    # the palette's widest shading, 1/64 to 64
# a box's histograms: bins over L*, a*, b*
STATISTICS_BINS = 32
STATISTICS_RANGES = (("L", 0.0, 100.0), ("a", -128.0, 128.0),
                     ("b", -128.0, 128.0))


class Teaching:
    """The boxes taught so far, on the frames they were drawn on, and the
    palette they are learned beside (immutable: each box makes a new
    one, so undo takes the one before).

    The boxes are learned together by ``palette.learn_from_images`` with
    ``palette learn``'s defaults (several references per class, the rest
    of the frames as "untaught"), then take their places in the base
    palette: a class taught keeps its place, a new one comes after. The
    rest of the frames is learned only when no class of the base is left
    beside the taught ones (it would take their colours)."""

    def __init__(self, base: pal.Palette, lessons=(), roles=None,
                 shading=None):
        self.base = base
        # (frame id, frame, (name, x, y, w, h)) in the order taught
        self.lessons: Tuple[Tuple[int, np.ndarray, tuple], ...] = \
            tuple(lessons)
        self.roles: Dict[str, str] = dict(roles or {})
        # the tolerances set on the page, kept when a class is re-taught
        self.shading: Dict[str, Tuple[float, float]] = dict(shading or {})

    def add(self, frame_id: int, frame: np.ndarray, rect: tuple,
            role: str) -> "Teaching":
        return Teaching(self.base, self.lessons + ((frame_id, frame, rect),),
                        {**self.roles, rect[0]: role}, self.shading)

    def edited(self, palette: pal.Palette, rename: Dict[str, str],
               shading=None) -> "Teaching":
        """The teaching after the user edited the palette into
        ``palette`` (a class renamed by ``rename``, old: new): the boxes
        of the classes still in it, learned beside it (so an edited class
        stays as edited, and the classes keep their places), except the
        untaught rest, which is learned again."""
        def keep(by_name):
            return {rename.get(n, n): v for n, v in by_name.items()
                    if rename.get(n, n) in palette.names}
        lessons = [(i, f, (rename.get(r[0], r[0]),) + tuple(r[1:]))
                   for i, f, r in self.lessons]
        base = [c for c in palette.classes if c.name != UNTAUGHT_CLASS or
                c.name in self.base.names]
        return Teaching(pal.Palette(base),
                        [x for x in lessons if x[2][0] in palette.names],
                        keep(self.roles), {**keep(self.shading),
                                           **(shading or {})})

    def frames(self) -> List[Tuple[int, np.ndarray, List[tuple]]]:
        """(frame id, frame, its boxes) in the order first taught on."""
        grouped: Dict[int, Tuple[int, np.ndarray, List[tuple]]] = {}
        for frame_id, frame, rect in self.lessons:
            grouped.setdefault(frame_id, (frame_id, frame, []))[2] \
                .append(rect)
        return list(grouped.values())

    def learn(self) -> Tuple[pal.Palette, List[str], Dict[str, float]]:
        """The palette, the warnings of paletteaudit (texts) and the
        spreads of the taught classes."""
        frames = self.frames()
        kept = [c for c in self.base.classes if c.name not in self.roles]
        by_role = {r: [n for n, role in self.roles.items() if role == r]
                   for r in ("background", "floor")}
        learned = pal.learn_from_images(
            [(frame, rects) for _, frame, rects in frames],
            background=by_role["background"], floor=by_role["floor"],
            references=TEACH_REFERENCES,
            untaught_class=None if kept else UNTAUGHT_CLASS,
            sources=[f"frame {frame_id}" for frame_id, _, _ in frames])
        findings, spread = paletteaudit.teaching_findings(learned, [
            (f"frame {frame_id}",
             reference.rgb_to_lab(np.ascontiguousarray(frame[:, :, ::-1])),
             rects) for frame_id, frame, rects in frames])
        new = {c.name: dataclasses.replace(
            c, shading=self.shading.get(c.name, c.shading))
            for c in learned.classes}
        classes = [new.pop(c.name, c) for c in self.base.classes]
        palette = pal.parse_palette(pal.palette_to_json(
            pal.Palette(classes + list(new.values()))), "teach")
        return palette, [f.text for f in findings], spread


class FrozenFrames:
    """Frames kept to teach on, by the id ``freeze`` returns (the newest
    FROZEN_KEPT: one per browser), so that a box is learned on the frame
    it was drawn on while the video goes on. Apart so that teaching and
    the box statistics name a frame and never reach into the stream:
    ``newest`` gives the newest frame and its pts."""

    def __init__(self, newest: Callable[[], Tuple[Optional[np.ndarray],
                                                   Optional[float]]]):
        self.newest = newest
        self.by_id: Dict[int, Dict[str, Any]] = {}
        self._serial = 0

    def freeze(self) -> Dict[str, Any]:
        """Keeps the newest frame to teach on; its id, pts and size (the
        page shows ``jpeg(id)`` while a box is drawn on it)."""
        frame, pts = self.newest()
        if frame is None:
            raise ConsoleError("freeze: no frame yet")
        ok, jpg = cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, 90])
        self._serial += 1
        self.by_id[self._serial] = {
            "frame": frame, "pts": pts, "jpeg": jpg.tobytes()}
        while len(self.by_id) > FROZEN_KEPT:
            self.by_id.pop(next(iter(self.by_id)))
        return {"frame": self._serial, "pts": pts,
                "width": frame.shape[1], "height": frame.shape[0]}

    def jpeg(self, frame_id) -> bytes:
        return self.kept(frame_id)["jpeg"]

    def kept(self, frame_id) -> Dict[str, Any]:
        """The frame ``frame_id`` (its "frame", "pts" and "jpeg")."""
        if not isinstance(frame_id, int) or isinstance(frame_id, bool):
            raise ConsoleError(f"frame must be the id freeze returned, got "
                               f"{json.dumps(frame_id)}")
        if frame_id not in self.by_id:
            raise ConsoleError(f"frame {frame_id} is no longer kept (the "
                               f"newest {FROZEN_KEPT} are): freeze again")
        return self.by_id[frame_id]


class LivePalette:
    """The palette labsegment runs with and the page's changes to it:
    boxes taught, classes deleted, renamed or given a tolerance, undo,
    save. Each change writes a new palette file and points labsegment
    at it. Apart from the engine because none of this needs the pipeline
    but that one element (``labsegment`` gives it, None without a
    pipeline) and the frames kept in ``frozen``."""

    def __init__(self, palette_path: Optional[str], out_dir: str,
                 live_files: LiveFiles, frozen: FrozenFrames,
                 labsegment: Callable[[], Optional[Gst.Element]]):
        self.palette = (pal.load_palette(palette_path) if palette_path
                        else pal.default_palette())
        self.palette_path = palette_path
        self.undo_stack: List[Tuple[pal.Palette, Optional[str],
                                    Teaching]] = []
        # the boxes taught so far and the palette they are learned beside
        self.teaching = Teaching(self.palette)
        self.teach_warnings: List[str] = []
        self.palette_spread: Dict[str, float] = {}
        self.out_dir = out_dir
        self._live_files = live_files
        self._frozen = frozen
        self._labsegment = labsegment

    def palette_json(self) -> Dict[str, Any]:
        return pal.palette_to_json(self.palette)

    def _apply_palette(self, palette: pal.Palette) -> None:
        """Writes ``palette`` to a new file and points labsegment at it
        (a new name each time: the element reads the file on the next
        frame)."""
        path = self._live_files.new_path("palette", ".json")
        pal.save_palette(palette, path)
        labsegment = self._labsegment()
        if labsegment is not None:
            labsegment.set_property("palette", path)
        self.palette, self.palette_path = palette, path
        self._live_files.keep("palette", path)

    def _remember(self) -> None:
        """What undo goes back to (the newest UNDO_DEPTH kept)."""
        self.undo_stack.append((self.palette, self.palette_path,
                                self.teaching))
        del self.undo_stack[:-UNDO_DEPTH]

    def teach(self, name: str, x, y, w, h,
              marker: Optional[bool] = None, frame_id=None,
              role: Optional[str] = None) -> Dict[str, Any]:
        """Adds the box of class ``name`` on the frozen frame ``frame_id``
        (None: the newest frame, frozen now) to the boxes taught so far,
        learns the palette from all of them as ``palette learn --rect``
        does and applies it; returns the class's new entry. ``role`` (or
        the older ``marker``) None: a new class is a marker, a known one
        keeps its role."""
        check_box("teach", x, y, w, h)
        if marker is not None and not isinstance(marker, bool):
            raise ConsoleError("teach: marker must be true or false")
        if not isinstance(name, str):
            raise ConsoleError("teach: class must be a string")
        if role is not None and role not in pal.ROLES:
            raise ConsoleError(f"teach: role must be one of "
                               f"{', '.join(pal.ROLES)}, got "
                               f"{json.dumps(role)}")
        if frame_id is None:
            if self._frozen.newest()[0] is None:
                raise ConsoleError("teach: no frame yet")
            frame_id = self._frozen.freeze()["frame"]
        frame = self._frozen.kept(frame_id)["frame"]
        lessons = self.teaching.add(frame_id, frame, (name, x, y, w, h),
                                    self._role(name, role, marker))
        try:
            palette, warnings, spread = lessons.learn()
        except pal.PaletteError as err:
            raise ConsoleError(f"teach: {err}") from None
        self._remember()
        self.teaching = lessons
        self.teach_warnings, self.palette_spread = warnings, spread
        self._apply_palette(palette)
        return next(c for c in self.palette_json()["classes"]
                    if c["name"] == name)

    def _role(self, name: str, role: Optional[str],
              marker: Optional[bool]) -> str:
        """The role ``name`` is taught with: ``role``; else a known class
        keeps its own (marker false keeps floor or background, makes a
        marker background); else a marker unless marker is false."""
        if role is not None:
            return role
        known = self.teaching.roles.get(name)
        if known is None and name in self.palette.names:
            known = self.palette.classes[self.palette.index(name)].role
        if known is None:
            return "background" if marker is False else "marker"
        return "background" if marker is False and known == "marker" \
            else known

    def new_palette(self) -> None:
        """The next boxes taught make a palette of their own (as
        ``palette learn`` does, the rest of the frame learned as
        "untaught"); the palette in force stays until then."""
        self._remember()
        self.teaching = Teaching(pal.Palette([]))
        self.teach_warnings, self.palette_spread = [], {}

    def edit_class(self, name, action: str, to=None) -> Dict[str, Any]:
        """Deletes the class ``name`` (``action`` "delete"), renames it
        ``to`` ("rename") or sets its tolerance ``to`` ("tolerance": it
        stands for its colours from 1/to to to times the light taught in,
        the palette's "shading"); applies the palette (undo takes it
        back)."""
        names = self.palette.names
        if not isinstance(name, str) or name not in names:
            raise ConsoleError(f"{action}: no class {json.dumps(name)} "
                               f"(classes: {', '.join(names)})")
        rename, shading, change = {}, None, {}
        if action == "delete":
            if len(names) == 1:
                raise ConsoleError(f"delete: {name} is the only class")
        elif action == "rename":
            if not isinstance(to, str) or to in names:
                raise ConsoleError(f"rename: the new name must be a string "
                                   f"that no class has, got "
                                   f"{json.dumps(to)}")
            rename, change = {name: to}, {"name": to}
        elif action == "tolerance":
            if not is_number(to) or not 1 <= to <= MAX_TOLERANCE:
                raise ConsoleError(f"tolerance: {name}: expected a light "
                                   f"factor from 1 (the taught colours "
                                   f"only) to {MAX_TOLERANCE:g}, got "
                                   f"{json.dumps(to)}")
            shading = {name: (1 / to, float(to))}
            change = {"shading": shading[name]}
        else:
            raise ConsoleError(f"action must be delete, rename or "
                               f"tolerance, got {json.dumps(action)}")

        # the class changed, or without a change deleted
        classes = [dataclasses.replace(c, **change) if c.name == name
                   else c for c in self.palette.classes
                   if change or c.name != name]
        try:
            palette = pal.parse_palette(pal.palette_to_json(
                pal.Palette(classes)), action)
        except pal.PaletteError as err:
            raise ConsoleError(f"{action}: {err}") from None
        self._remember()
        self.teaching = self.teaching.edited(palette, rename, shading)
        self.palette_spread = {rename.get(n, n): v for n, v in
                               self.palette_spread.items()
                               if rename.get(n, n) in palette.names}
        self._apply_palette(palette)
        return {"palette": self.palette_json()}

    def box_statistics(self, frame_id, x, y, w, h) -> Dict[str, Any]:
        """Mean, spread (standard deviation) and histograms in L*a*b* of
        the pixels in a box of a frozen frame (None: the newest frame)."""
        frame = self._frozen.newest()[0] if frame_id is None else \
            self._frozen.kept(frame_id)["frame"]
        if frame is None:
            raise ConsoleError("statistics: no frame yet")
        check_box("statistics", x, y, w, h)
        try:
            pal.check_rects(frame.shape, [("box", x, y, w, h)])
        except pal.PaletteError as err:
            raise ConsoleError(f"statistics: {err}") from None
        rgb = np.ascontiguousarray(frame[y:y + h, x:x + w, ::-1])
        pixels = reference.rgb_to_lab(rgb).reshape(-1, 3) \
            .astype(np.float64)
        out: Dict[str, Any] = {"pixels": len(pixels),
                               "mean": pixels.mean(axis=0).tolist(),
                               "std": pixels.std(axis=0).tolist(),
                               "histograms": {}}
        for k, (channel, lo, hi) in enumerate(STATISTICS_RANGES):
            counts, edges = np.histogram(pixels[:, k], STATISTICS_BINS,
                                         (lo, hi))
            out["histograms"][channel] = {"from": lo, "to": hi,
                                          "counts": counts.tolist()}
        return out

    def undo(self) -> None:
        if not self.undo_stack:
            raise ConsoleError("nothing to undo")
        previous, _, self.teaching = self.undo_stack.pop()
        self.teach_warnings = []
        if previous is not self.palette:
            self._apply_palette(previous)

    def save_palette(self) -> str:
        path = os.path.join(self.out_dir, "palette.json")
        # the spreads as palette learn writes them: palette check reads
        extra = {"spread": self.palette_spread} if self.palette_spread \
            else {}
        pal.save_palette(self.palette, path,
                         description="Saved by gst-landmark console.",
                         **extra)
        return path
