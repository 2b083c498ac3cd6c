"""gst-landmark: colour landmark localisation with GStreamer.

Submodules:
  meta       read the metadata our elements attach to buffers
  palette    load, validate and learn colour palettes
  reference  plain numpy/OpenCV implementation of the algorithms (test oracle)
  cli        the ``gst-landmark`` command
"""

__version__ = "0.1.0"
