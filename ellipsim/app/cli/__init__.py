"""The `ellipsim` command line: a module per command (its arguments, `add_parser`, and its function),
over `common` (argument types, progress, output files, the options they share).

    ellipsim run SCENARIO|MODEL.xml [--steps N] [--mode builtin|filter|narrowphase] [--record FILE.rrd]
                 [--key NAME|INDEX] [--ctrl hold|zero|keyframe] [--[no-]between-frames]
    ellipsim compare SCENARIO|MODEL.xml [--steps N] [--json FILE] [--plot FILE.png] [--key ..] [--ctrl ..]
                 [--[no-]between-frames]
    ellipsim replay MODEL.xml MOTION.npy|.csv [--fps F] [--record FILE.rrd] [--json FILE] [--[no-]between-frames]
    ellipsim fit MESH... [--method thesis|mvee] [--out limbs.xml]
    ellipsim view FILE.rrd
    ellipsim sweep SCENARIO|MODEL.xml --vary KEY=V1,V2,... [--vary ...] [--seeds N] [--steps N] [--mode M]
                   [--record] --out DIR [--backend local|ray] [--workers N]
    ellipsim bench [--quick] [--only SECTION ...] [--out DIR]
    ellipsim list
    ellipsim demo [--pairs N] [--seed S]
    ellipsim --version

SCENARIO is a name from `ellipsim list` or a path to a .toml file; MODEL.xml any MJCF file (its
includes and assets are found relative to it, as MuJoCo does).  A user mistake (unknown scenario,
malformed file, bad argument, a request larger than memory) ends with one line on stderr and exit
status 2; Ctrl-C with one line and status 130, SIGTERM with status 143: a recording being written
then keeps the frames so far (completed, then renamed into place: never left half-written), and the
line says at which step and how many frames, e.g. `ellipsim: interrupted at step 812/1500; recording
of 102 frames kept in handshake.rrd`.
"""

import os
import signal
import sys

import ellipsim

from ..errors import Terminated, UserError
from . import bench, compare, demo, fit, fix, replay, run, scenarios, sweep, view
from .common import Parser, Progress, end_lines, progress_bars, stop_notes

__all__ = ["main", "parser", "script", "Progress", "UserError"]

#: The subcommands, in the order --help lists them.
COMMANDS = (run, compare, replay, fix, fit, sweep, view, bench, scenarios, demo)


def parser():
    """The `ellipsim` argument parser: a subcommand per module of COMMANDS, in that order."""
    p0 = Parser(
        prog="ellipsim",
        description="Exact, fast ellipsoid collision detection for MuJoCo figures with oval limbs.",
        epilog="examples: ellipsim run handshake --record handshake.rrd ; ellipsim run model.xml --key stand ; "
        "ellipsim replay model.xml walk.npy --json walk.json ; ellipsim compare pile --json pile.json",
    )
    p0.add_argument("--version", action="version", version=f"ellipsim {ellipsim.__version__}")
    sub = p0.add_subparsers(dest="command", required=True, parser_class=Parser)
    for command in COMMANDS:
        command.add_parser(sub)
    return p0


def _terminate(signum, frame):
    raise Terminated()


def main(argv=None):
    args = parser().parse_args(argv)
    previous = None
    try:
        previous = signal.signal(signal.SIGTERM, _terminate)  # this process is the command: unwind on SIGTERM
    except ValueError:  # not the main thread (main() called from a thread): leave signals alone
        pass
    progress_bars.clear()
    stop_notes.clear()
    try:
        return args.run(args)
    except UserError as exc:  # errors.UserError: the scenario's, model's, motion's, sweep's errors too
        end_lines()
        print(f"ellipsim: error: {exc.cli_prefix}{exc}", file=sys.stderr)
        return 2
    except ImportError as exc:  # ellipsim.native.NativeImportError: the compiled core is unusable as installed
        if not getattr(exc, "one_line", False):
            raise
        end_lines()
        print(f"ellipsim: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        end_lines()
        print(" ".join(["ellipsim: interrupted", *stop_notes]), file=sys.stderr)
        return 130
    except Terminated:
        end_lines()
        print(" ".join(["ellipsim: terminated", *stop_notes]), file=sys.stderr)
        return 143
    except BrokenPipeError:  # `ellipsim ... | head`: the reader left, nothing to report
        sys.stderr.close()
        return 0
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def script():
    """The `ellipsim` command and `python -m ellipsim`: main(), then exit with its status.  After
    Ctrl-C or SIGTERM (status 130, 143) the one-line reason is the command's last word: standard
    error is pointed at the null device before the interpreter's teardown, where the threads of a
    stopped worker pool can still print (an EBADF on a closed pipe, seen once in CI on
    `ellipsim sweep --workers 2`).  Cleanup (atexit, the pool's semaphores) runs as usual."""
    code = main()
    if code in (130, 143):
        sys.stdout.flush()
        sys.stderr.flush()
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 2)
        os.close(null)
    return code
