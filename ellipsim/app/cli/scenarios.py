"""`ellipsim list`: the scenarios shipped with ellipsim."""


def list_scenarios(args):
    from .. import scenario

    for name in scenario.available():
        s = scenario.load(name)
        kind = "kinematic" if s.kinematic else s.mode
        print(f"{name:<12} {s.duration:g} s, {kind:<11} {s.description}")
    print("any MJCF model runs too: ellipsim run path/to/model.xml [--key NAME|INDEX] [--ctrl hold|zero|keyframe]")
    return 0


def add_parser(sub):
    """The `list` subcommand and its arguments."""
    p = sub.add_parser("list", help="list the scenarios shipped with ellipsim")
    p.set_defaults(run=list_scenarios)
