"""``gst-landmark synth``: render a named scenario with exact ground
truth."""

import math
import os

from ..palette import PaletteError
from ..synth.floors import FLOOR_NAMES
from ..synth.odometry import FRAMES, OdometryErrors
from ..synth.scenarios import DEFAULT_ROBOT, ROBOTS, SCENARIOS
from .common import CliError, size_type

DESCRIPTION = """\
Render a robot's camera view of a synthetic floor with coloured landmarks
by exact ray casting, with exact ground truth.  Writes, in --out:
clip.avi (MJPEG), truth.jsonl (per-frame landmark pixels, range,
bearing), scene.json, map.json, palette.json (the scene palette),
frame0.png and mask0.png (class mask of the first frame, values index
the scene palette), chart.png and chart-mask.png (a colour chart of
every palette class under frame 0's camera and lighting, for
'gst-landmark palette learn --mask').  Prints, and writes in scene.json,
the histogram of frames by landmarks visible with >= 150 pixels;
camera.yml, the true camera as a camera file for ipmrange calibration=;
and odometry.jsonl, wheel odometry from the true path with a scale
error, heading drift and slip, for landmarkslam odometry=.

The default robot is the seed's: a 54-degree 640x480 webcam 0.2 m above
the floor, tilted 18 degrees down, with 10 cm discs and 8 cm balls.
--robot comfortable is the wide-angle camera half a metre up with 30 cm
discs that the regression clips were made with.  --variant N draws a
camera, light, floor, marker sizes, photometry, layout and path from N
(docs/synth.md)."""

EPILOG = """\
scenarios:
  range-sweep   one disc or ball per frame, 0.3..4 m (comfortable:
                0.3..5 m), -20..20 degrees
  path          8 landmarks, 3 m x 3 m walled field (comfortable: 6 m x
                6 m), a 300-frame loop; three or more landmarks in view
                in most frames (comfortable camera: --hfov 80
                --cam-height 0.5 --tilt 20)
  backgrounds   the same landmarks over every floor, then an exposure
                and white-balance ramp
  distractors   landmarks among non-round patches and specks
  edge-cases    cut by the border, far, near, twice, occluded
  custom        --map FILE seen from --poses FILE or --pose X,Y,DEG

floors: """ + ", ".join(FLOOR_NAMES)


def _pose(text):
    try:
        x, y, heading = (float(v) for v in text.split(","))
    except ValueError:
        import argparse
        raise argparse.ArgumentTypeError(
            f"expected X,Y,HEADING_DEG, got {text!r}") from None
    return x, y, math.radians(heading)


def add_synth_parser(subparsers):
    import argparse
    p = subparsers.add_parser(
        "synth", help="render a synthetic clip with exact ground truth",
        description=DESCRIPTION, epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scenario", choices=list(SCENARIOS), metavar="SCENARIO",
                   help="one of: " + ", ".join(SCENARIOS))
    p.add_argument("--out", metavar="DIR",
                   help="output folder (default out/synth/SCENARIO)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--frames", type=int, metavar="N",
                   help="frame count (default: the scenario's)")
    p.add_argument("--size", type=size_type, default=(640, 480),
                   metavar="WxH", help="image size (default 640x480)")
    p.add_argument("--fps", type=int, default=None, help="default 30")
    p.add_argument("--robot", choices=ROBOTS, default=DEFAULT_ROBOT,
                   help="seed (default): 54-degree webcam 0.2 m up, tilt "
                        "18, 10 cm discs, 8 cm balls; comfortable: the "
                        "scenario's wide-angle camera 0.5 m up, 30 cm "
                        "discs")
    p.add_argument("--variant", type=int, metavar="N",
                   help="draw camera, light, floor, marker sizes, "
                        "photometry, layout and path from N (written in "
                        "scene.json); other options still win")

    cam = p.add_argument_group("camera")
    cam.add_argument("--hfov", type=float, dest="hfov_deg", metavar="DEG",
                     help="horizontal field of view (default: the "
                          "robot's, seed 54)")
    for name in ("fx", "fy", "cx", "cy"):
        cam.add_argument(f"--{name}", type=float, metavar="PX",
                         help="intrinsics in pixels instead of --hfov")
    cam.add_argument("--cam-height", type=float, dest="height_m",
                     metavar="M", help="camera height (default: the "
                                       "robot's, seed 0.2)")
    cam.add_argument("--tilt", type=float, dest="tilt_deg", metavar="DEG",
                     help="tilt below the horizontal (default: the "
                          "robot's, seed 18)")
    cam.add_argument("--roll", type=float, dest="roll_deg", metavar="DEG",
                     help="roll (default 0)")

    world = p.add_argument_group("world")
    world.add_argument("--floor", choices=FLOOR_NAMES,
                       help="one floor for the whole clip")
    walls = world.add_mutually_exclusive_group()
    walls.add_argument("--walls", dest="walls", action="store_const",
                       const=True, default=None,
                       help="walls around the field")
    walls.add_argument("--no-walls", dest="walls", action="store_const",
                       const=False)
    world.add_argument("--obstacles", type=int, metavar="N",
                       help="N boxes of random size and colour standing "
                            "in the field, off the camera's path; the "
                            "truth gains the free floor per bearing")
    files = {
        "--palette": "landmark colours: the marker classes of this palette "
                     "(default: the built-in palette)",
        "--map": "custom: the landmarks (map.json format)",
        "--poses": "custom: one pose per frame (JSON list or lines of "
                   "{\"x\", \"y\", \"heading\"}, rad)",
    }
    for flag, text in files.items():
        world.add_argument(flag, metavar="FILE", help=text)
    world.add_argument("--pose", type=_pose, metavar="X,Y,DEG",
                       help="custom: one static pose (heading in degrees)")

    fx = p.add_argument_group("rendering and effects")
    fx.add_argument("--supersample", type=int, metavar="N",
                    help="N x N rays per pixel at edges (default 4)")
    fx.add_argument("--jpeg-quality", type=int, metavar="Q",
                    help="MJPEG quality (default 90)")
    fx.add_argument("--noise", type=float, dest="noise_sigma",
                    metavar="SIGMA", help="sensor noise, 8-bit units "
                                          "(default 1.5)")
    fx.add_argument("--ball-shading", type=float, metavar="K",
                    help="0 flat .. 1 Lambert (default 0.5)")
    fx.add_argument("--exposure", type=float, dest="exposure_stops",
                    metavar="STOPS", help="exposure offset")
    fx.add_argument("--exposure-drift", type=float,
                    dest="exposure_drift_stops", metavar="STOPS",
                    help="amplitude of a slow exposure drift")
    fx.add_argument("--wb-drift", type=float, metavar="FRACTION",
                    help="amplitude of a slow white-balance drift")
    fx.add_argument("--drift-period", type=float, dest="drift_period_s",
                    metavar="S", help="period of the drifts (default 8)")
    fx.add_argument("--auto-exposure", type=float, metavar="K",
                    help="grey-world auto exposure strength 0..1")
    fx.add_argument("--auto-wb", type=float, metavar="K",
                    help="grey-world white balance strength 0..1")
    fx.add_argument("--vignette", type=float, metavar="K",
                    help="darkening at the corners, 0..1")
    fx.add_argument("--motion-blur", type=int, metavar="N",
                    help="average N sub-frames (slow: N times the work)")
    fx.add_argument("--shutter", type=float, metavar="FRACTION",
                    help="exposure time / frame interval (default 0.5)")

    odo = p.add_argument_group(
        "odometry log (odometry.jsonl, for landmarkslam odometry=)")
    odo.add_argument("--odometry-scale", type=float, default=0.02,
                     metavar="FRACTION",
                     help="translation scale error (default 0.02: 2 %%)")
    odo.add_argument("--odometry-drift", type=float, default=1.0,
                     metavar="DEG_PER_M",
                     help="heading drift per metre travelled (default 1)")
    # slip: random walks, sigma per square root of the distance or turn
    for name, default, unit, what in (
            ("slip", 0.0011, "M_PER_SQRT_M",
             "slip along and across per sqrt(metre) driven"),
            ("heading-slip", 0.0011, "RAD_PER_SQRT_M",
             "heading slip per sqrt(metre) driven"),
            ("turn-slip", 0.0018, "RAD_PER_SQRT_RAD",
             "heading slip per sqrt(radian) turned")):
        odo.add_argument(f"--odometry-{name}", type=float, default=default,
                         metavar=unit, help=f"{what} (default {default})")
    odo.add_argument("--odometry-frame", choices=FRAMES, default="camera",
                     help="whose motion the log reports: the camera's "
                          "floor point (default) or the turning centre "
                          "the camera is camera_forward_m ahead of")
    odo.add_argument("--odometry-rate", type=float, metavar="HZ",
                     help="steps at this rate, between frames as a real "
                          "encoder's (default: one per frame)")
    odo.add_argument("--odometry-seed", type=int, metavar="N",
                     help="seed of the odometry's slip draws (default: "
                          "the scenario's seed): another draw of the log "
                          "for the same clip")
    odo.add_argument("--no-odometry", dest="odometry", action="store_false",
                     help="write no odometry log")

    out = p.add_argument_group("outputs")
    out.add_argument("--frames-png", metavar="DIR",
                     help="also write lossless frames DIR/000000.png ...")
    out.add_argument("--raw", metavar="FILE",
                     help="also write raw RGB frames (caps in scene.json)")
    out.add_argument("--masks", choices=("first", "all"), default="first",
                     help="class masks of the first frame only (default) "
                          "or of all frames (masks/000000.png ...)")
    prog = out.add_mutually_exclusive_group()
    prog.add_argument("--progress", dest="progress", action="store_const",
                      const=True, default=None,
                      help="progress bar on stderr (default: when stderr "
                           "is a terminal)")
    prog.add_argument("--no-progress", dest="progress",
                      action="store_const", const=False)
    p.set_defaults(handler=_handle, parser=p)


OVERRIDE_ARGS = ("fps", "hfov_deg", "fx", "fy", "cx", "cy", "height_m",
                 "tilt_deg", "roll_deg", "floor", "walls", "obstacles",
                 "palette", "map",
                 "poses", "pose", "supersample", "jpeg_quality",
                 "noise_sigma", "ball_shading", "exposure_stops",
                 "exposure_drift_stops", "wb_drift", "drift_period_s",
                 "auto_exposure", "auto_wb", "vignette", "motion_blur",
                 "shutter")


def _handle(args):
    from ..pipeline import PipelineError
    from ..synth.writer import format_visibility, render_scenario

    if args.hfov_deg is not None and args.fx is not None:
        args.parser.error("give --hfov or --fx, not both")
    if args.scenario != "custom" and any(
            getattr(args, k) is not None for k in ("map", "poses", "pose")):
        args.parser.error("--map, --poses and --pose go with the custom "
                          "scenario")
    if args.variant is not None and args.variant < 0:
        args.parser.error("--variant must be >= 0")
    if args.scenario == "custom" and args.map is None:
        args.parser.error("the custom scenario needs --map FILE")
    out = args.out or os.path.join("out", "synth", args.scenario)
    odometry = args.odometry and OdometryErrors(
        scale=args.odometry_scale, drift_deg_per_m=args.odometry_drift,
        slip=args.odometry_slip, heading_slip=args.odometry_heading_slip,
        turn_slip=args.odometry_turn_slip, rate_hz=args.odometry_rate,
        frame=args.odometry_frame, seed=args.odometry_seed)
    overrides = {k: getattr(args, k) for k in OVERRIDE_ARGS
                 if getattr(args, k) is not None}
    try:
        summary = render_scenario(
            args.scenario, out, seed=args.seed, frames=args.frames,
            size=args.size, progress=args.progress, robot=args.robot,
            variant=args.variant, odometry=odometry,
            frames_png=args.frames_png, raw=args.raw, masks=args.masks,
            **overrides)
    except (ValueError, OSError, PaletteError, PipelineError) as err:
        raise CliError(str(err)) from None
    width, height = summary["size"]
    print(f"{args.scenario}: {summary['frames']} frames of "
          f"{width}x{height} in {summary['seconds']:.1f} s "
          f"({summary['frames_per_second']:.1f} frames/s), "
          f"{summary['landmark_sightings']} landmark sightings")
    print(format_visibility(summary["visibility"]))
    written = ["truth.jsonl", "scene.json", "map.json", "palette.json",
               "camera.yml", "frame0.png", "mask0.png"]
    if "chart" in summary["files"]:
        written += ["chart.png", "chart-mask.png"]
    if "odometry" in summary["files"]:
        written.append("odometry.jsonl")
    print(f"wrote {out}/clip.avi, {', '.join(written)}")
    return 0
