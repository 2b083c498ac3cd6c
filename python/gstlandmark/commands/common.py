"""What every command shares: the program name and the error a handler
raises for bad input (``cli.main`` prints it and exits with its status)."""

PROG = "gst-landmark"


class CliError(Exception):
    """Bad input found while running a command (exit status 1)."""

    def __init__(self, message, status=1):
        super().__init__(message)
        self.status = status
