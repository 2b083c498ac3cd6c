"""Developer tools: benchmarks, regression goldens, soak and valgrind runs,
the accuracy sweep, one frame of a recording drawn as a viewer shows it
(mcapview). They may import the library and the commands; neither imports
them (``commands.cli`` only lists the ones that are sub-commands, by
name)."""
