"""`ellipsim fit`: bounding ellipsoids of meshes (fit.fit_limb), printed and written as MJCF."""

import os

from ..errors import UserError
from .common import check_output, made_parents, positive_int, write_error


def fit(args):
    """Bounding ellipsoids of meshes, printed to a sensible precision and optionally written as MJCF."""
    from .. import fit as fitting

    if args.out:
        check_output(args.out, ".xml", "--out")
    names = [os.path.splitext(os.path.basename(p))[0] or "limb" for p in args.meshes]
    if len(set(names)) != len(names):
        names = [f"{n}_{i}" for i, n in enumerate(names)]
    limbs = []
    for name, path in zip(names, args.meshes):
        try:
            limbs.append(fitting.fit_limb(name, path, method=args.method, digits=args.digits))
        except ValueError as exc:
            raise UserError(str(exc)) from None
    print("\n".join(fitting.summary_lines(limbs, method=args.method, digits=args.digits)))
    if args.out:
        made_parents(args.out, "--out")
        try:
            with open(args.out, "w") as f:
                f.write(fitting.limbs_xml(limbs, method=args.method))
        except OSError as exc:
            raise write_error("--out", args.out, exc) from None
        print(f'  MJCF: {args.out} (<include file="{os.path.basename(args.out)}"/> adds the geoms to a worldbody)')
    return 0


def add_parser(sub):
    """The `fit` subcommand and its arguments."""
    p = sub.add_parser(
        "fit",
        help="bounding ellipsoids of meshes (.obj .stl .ply .off .glb .gltf), as MJCF geoms",
        epilog="example: ellipsim fit forearm.stl hand.stl --method mvee --out limbs.xml",
    )
    p.add_argument("meshes", nargs="+", metavar="MESH", help="mesh files, one ellipsoid each (named after the file)")
    p.add_argument(
        "--method",
        choices=("thesis", "mvee"),
        default="thesis",
        help="thesis: covariance of the convex hull (default); mvee: minimum-volume enclosing ellipsoid",
    )
    p.add_argument("--out", metavar="FILE.xml", help="write the ellipsoids as MJCF geoms")
    p.add_argument("--digits", type=positive_int, default=6, help="significant digits of the numbers (default 6)")
    p.set_defaults(run=fit)
