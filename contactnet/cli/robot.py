"""`contactnet robot init | check`: a robot file drafted from a URDF, and whether a robot is ready to walk here."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from contactnet import registry
from contactnet.cli.types import SIM_HELP, UserError, robot_argument, sim_of
from contactnet.sim.world import ENGINES as SIM_ENGINES


def add_robot_parser(sub) -> None:  # noqa: ANN001 - argparse's subparsers
    """The ``robot`` command and its actions ``init`` and ``check``."""
    robot = sub.add_parser("robot", help="check that a robot is ready to walk here")
    rsub = robot.add_subparsers(dest="robot_cmd", metavar="ACTION", required=True)
    check = rsub.add_parser("check", help="model against simulator, stance, stand 10 s, walk and trot 20 s; a verdict")
    check.add_argument("robot", type=robot_argument, metavar="ROBOT",
                       help=f"the robot ({', '.join(registry.robot_names())}) or a robot file (FILE.toml)")
    check.add_argument("--sim", choices=SIM_ENGINES, help=SIM_HELP)
    check.add_argument("--json", action="store_true")
    init = rsub.add_parser("init", help="draft a robot file from a URDF (+ SRDF) or an example-robot-data folder")
    init.add_argument("source", metavar="SOURCE", help="a folder of example-robot-data (e.g. a1_description) or a URDF")
    init.add_argument("--srdf", metavar="FILE.srdf", help="the SRDF of a URDF given as a file (default: found beside it)")
    init.add_argument("--name", help="the robot's name (default: the URDF's file name)")
    init.add_argument("--out", required=True, metavar="FILE.toml")
    init.add_argument("--force", action="store_true", help="overwrite FILE.toml")
    robot.set_defaults(func=cmd_robot)


def cmd_robot(args: argparse.Namespace) -> int:
    """``robot init``: write the drafted file and say what was guessed. ``robot check``: exit 0 when the robot is
    ready, 1 when a check failed (the table says which)."""
    if args.robot_cmd == "init":
        from contactnet.atomic import atomic_write_text
        from contactnet.robots.robot_file import load_robot_file, to_toml
        from contactnet.robots.robot_init import draft

        out = Path(args.out)
        if out.suffix != ".toml":
            raise UserError(f"--out {out}: a robot file ends in .toml")
        if out.exists() and not args.force:
            raise UserError(f"{out} exists; pass --force to overwrite it")
        drafted = draft(args.source, args.srdf, args.name)
        atomic_write_text(out, f"# drafted by: contactnet robot init {args.source}\n"
                          + "".join(f"# guessed: {line}\n" for line in drafted.problems) + to_toml(drafted.values))
        load_robot_file(out)  # what was written reads back
        for line in drafted.problems:
            print(f"guessed: {line}")
        print(f"wrote {out}; next: contactnet robot check {out}")
        return 0
    from contactnet.jobs.robot_check import check_robot, checks_as_json, format_checks

    engine = sim_of(args)
    checks = check_robot(registry.load_robot(args.robot), engine)
    if args.json:
        print(json.dumps(checks_as_json(args.robot, engine, checks), indent=1))
    else:
        print(format_checks(args.robot, checks))
    return 0 if all(c.passed for c in checks) else 1


__all__ = ["add_robot_parser", "cmd_robot"]
