"""`ellipsim view`: a recording in the rerun viewer."""

from ..errors import UserError


def view(args):
    from .. import record

    try:
        return record.view(args.file)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def add_parser(sub):
    """The `view` subcommand and its arguments."""
    p = sub.add_parser("view", help="open a recording in the rerun viewer (or say how)")
    p.add_argument("file", metavar="FILE.rrd")
    p.set_defaults(run=view)
