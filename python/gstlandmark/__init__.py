"""gst-landmark: colour landmark localisation with GStreamer.

The package has three layers; each imports only from the ones above it
(tests/python/test_layers.py checks this and that there is no import
cycle):

The library (this folder), what applications import:
  meta         read the metadata our elements attach to buffers
  messages     typed views of the elements' ``landmark-*`` messages
  gicompat     what moved between GStreamer 1.22 and 1.26 (PyGObject 3.42, 3.50)
  pipeline     run our elements from Python (frames in, results out)
  plugin       find the plugin the set-up built (used by pipeline.init)
  pipelinefile the shipped pipeline files (package data)
  palette      load, validate and learn colour palettes
  landmarkmap  read landmark map files (the one reader)
  landmarklog  read landmarklog (JSON Lines) files
  camerafile   read and write camera files (OpenCV and ROS camera_info)
  reference    plain numpy/OpenCV implementation of the algorithms
  webguard     the access rules of the project's web pages
  synth        the synthetic world with exact ground truth

commands/: the ``gst-landmark`` command (``commands.cli``) and its
  sub-commands (run, demo, calibrate, evaluate, synth, record, fleet,
  console, floormap, palette).

devtools/: developer tools: benchmarks, regression goldens and
  ``regress``, soak and valgrind runs, the accuracy sweep, ``mcapview``
  (one frame of a recording drawn as a viewer shows it).
"""

__version__ = "0.1.0"
