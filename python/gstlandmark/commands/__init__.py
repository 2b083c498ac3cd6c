"""The ``gst-landmark`` command and its sub-commands (``cli.main`` is the
entry point). Commands import the library (``gstlandmark``'s top-level
modules and ``synth``); the library imports nothing from here."""
