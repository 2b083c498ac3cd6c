"""What every command shares: the program name, the error a handler
raises for bad input (``cli.main`` prints it and exits with its status)
and the options and files several commands take alike."""

import argparse

PROG = "gst-landmark"


class CliError(Exception):
    """Bad input found while running a command (exit status 1)."""

    def __init__(self, message, status=1):
        super().__init__(message)
        self.status = status


def size_type(text):
    """argparse type for WIDTHxHEIGHT (both at least 1) -> (w, h)."""
    try:
        width, height = (int(v) for v in text.lower().split("x"))
        if width < 1 or height < 1:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected WIDTHxHEIGHT, got {text!r}") from None
    return width, height


def add_actions(parser, dest="action", metavar="ACTION"):
    """The sub-parsers of a command whose first word picks what it does
    (``palette learn``, ``calibrate seed``): one is required."""
    return parser.add_subparsers(dest=dest, metavar=metavar, required=True)


def add_token_option(parser, what="access token"):
    """``--token`` of a command that serves a page (webguard's rules:
    ``webguard.choose_token`` picks the default)."""
    parser.add_argument("--token", metavar="T",
                        help=f"{what} (at least 16 characters; default: "
                             f"none on loopback, a random one printed at "
                             f"start otherwise)")


def add_json_option(parser, what="the numbers", dash_o=False):
    """``--json OUT`` (and ``-o OUT`` with dash_o, for a command with no
    other output file): a command's results also written as JSON."""
    flags = ("-o", "--json") if dash_o else ("--json",)
    parser.add_argument(*flags, metavar="OUT",
                        help=f"also write {what} to this JSON file")


def camera_and_map(camera_path, map_path):
    """(the camera file with its mounting, the map's landmarks), each
    None when its path is; CliError naming the file when one is bad or
    the camera has no mounting (record and run --foxglove place the
    camera with it)."""
    from ..camerafile import CalibrationError, read_camera_file, \
        read_mounting
    from ..landmarkmap import MapError, read_map
    camera = landmarks = None
    try:
        if camera_path:
            camera = read_camera_file(camera_path)
            camera.update(read_mounting(camera_path))
        if map_path:
            landmarks = read_map(map_path)
    except (CalibrationError, MapError, OSError) as err:
        raise CliError(str(err)) from None
    if camera is not None and "camera_height" not in camera:
        raise CliError(f"{camera_path}: no camera_height (the mounting: "
                       f"write it with 'gst-landmark calibrate floor')")
    return camera, landmarks
