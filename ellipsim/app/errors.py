"""User errors: the one base class of every error a bad file, value or argument raises in the
application (scenario.ScenarioError, mjcf.ModelError, replay.MotionError, sweep.SweepError), so
that the command line catches one type and reports it in one line, exit status 2 (style.md 11); and
Terminated, what SIGTERM raises, which stops a command as Ctrl-C does.
"""


class UserError(ValueError):
    """A mistake in what the user asked for; the message (one line) names the file, key or argument
    and the value."""

    #: What the command line writes before the message: "--" where the message starts with the
    #: name of an argument that the command line takes as an option of that name (sweep.SweepError).
    cli_prefix = ""


class Terminated(BaseException):
    """SIGTERM arrived (the command line raises it from its handler): unwinds like KeyboardInterrupt."""


#: The exceptions that stop a command on the user's request: Ctrl-C and SIGTERM.  A recording being
#: written keeps the frames written so far (record.Recorder with keep_partial=True).
STOPS = (KeyboardInterrupt, Terminated)
