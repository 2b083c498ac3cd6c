"""Developer tools that are sub-commands: benchmarks, regression goldens,
soak and valgrind runs, the accuracy sweep, one frame of a recording drawn
as a viewer shows it (mcapview). They may import the library and the
commands; only the dispatcher (``commands.cli``) loads them, by name, so
they never import it: one that runs a command starts ``gst-landmark`` in a
process of its own (``benchkit.run_command``). Research scripts live in
the source tree's ``tools/``, outside the package."""
