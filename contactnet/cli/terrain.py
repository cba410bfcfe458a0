"""`contactnet terrain list | check | render | save | import`: the terrains, looked at, saved and brought in."""

from __future__ import annotations

import argparse
from pathlib import Path

from contactnet import registry
from contactnet.cli.types import (
    HEIGHT_HELP,
    ROBOT_METAVAR,
    UserError,
    bounded_float,
    number_list,
    robot_argument,
)


def add_terrain_parser(sub) -> None:  # noqa: ANN001 - argparse's subparsers
    """The ``terrain`` command and its actions."""
    from contactnet.terrain import SegmentConfig

    terrain = sub.add_parser("terrain", help="check, render, list, save and import terrains")
    tsub = terrain.add_subparsers(dest="terrain_cmd", metavar="ACTION", required=True)
    tsub.add_parser("list", help="names of the shipped terrains")
    for action, text in (
        ("check", "validate a terrain and print its summary"),
        ("render", "draw a top view to PNG"),
        ("save", "write a (generated) terrain to a JSON file"),
    ):
        t = tsub.add_parser(action, help=text)
        t.add_argument("terrain", help="terrain name or JSON path ('random' with --removed)")
        t.add_argument("--removed", type=int, default=None)
        t.add_argument("--height", type=bounded_float("--height", 0.0, 0.5), default=None, metavar="H",
                       help=HEIGHT_HELP)
        t.add_argument("--seed", type=int, default=0)
        if action in ("render", "save"):
            t.add_argument("--out", required=action == "save")
        if action == "render":
            t.add_argument("--robot", type=robot_argument, metavar=ROBOT_METAVAR, default=registry.DEFAULT_ROBOT,
                           help="whose nominal feet are drawn at the start (default solo12)")
        if action == "save":
            t.add_argument("--force", action="store_true")
    imp = tsub.add_parser("import", help="a terrain from a height map (.npy, .png) or a mesh (.stl, .obj, .ply)")
    imp.add_argument("source", metavar="SOURCE")
    imp.add_argument("--out", required=True, metavar="FILE.json")
    imp.add_argument("--resolution", type=bounded_float("--resolution", 1e-4, 10.0), default=None, metavar="M",
                     help="metres per pixel of a height map (default 0.01); a mesh's sampling step (default 0.002)")
    imp.add_argument("--z-scale", type=bounded_float("--z-scale", 1e-9, 1e3), default=1.0,
                     help="metres per unit of the map's values (e.g. 0.001 for millimetres in a 16-bit PNG)")
    imp.add_argument("--origin", type=number_list("--origin", -1e3, 1e3), default=(0.0, 0.0), metavar="X,Y",
                     help="where map[0, 0] lies (m)")
    imp.add_argument("--start", type=number_list("--start", -1e3, 1e3), default=None, metavar="X,Y")
    imp.add_argument("--goal-x", type=bounded_float("--goal-x", -1e3, 1e3), default=None, metavar="X")
    imp.add_argument("--name", default=None, help="the terrain's name (default: the file's)")
    defaults = SegmentConfig()
    imp.add_argument("--max-step", type=bounded_float("--max-step", 0.0, 1.0), default=defaults.max_step_m,
                     metavar="M", help=f"neighbours within this height are one top (default {defaults.max_step_m})")
    imp.add_argument("--max-spread", type=bounded_float("--max-spread", 0.0, 1.0), default=defaults.max_spread_m,
                     metavar="M", help=f"a flat top's heights within this (default {defaults.max_spread_m})")
    imp.add_argument("--max-roughness", type=bounded_float("--max-roughness", 0.0, 1.0),
                     default=defaults.max_roughness_m, metavar="M",
                     help=f"a sloped top's heights within this (std) of its plane (default {defaults.max_roughness_m})")
    imp.add_argument("--max-drop", type=bounded_float("--max-drop", 0.0, 100.0), default=defaults.max_drop_m,
                     metavar="M", help=f"deeper than this below the median: a hole (default {defaults.max_drop_m})")
    imp.add_argument("--min-width", type=bounded_float("--min-width", 0.0, 10.0), default=defaults.min_width_m,
                     metavar="M", help=f"narrower tops are dropped (default {defaults.min_width_m})")
    imp.add_argument("--force", action="store_true", help="overwrite FILE.json")
    terrain.set_defaults(func=cmd_terrain)


def cmd_terrain(args: argparse.Namespace) -> int:
    from contactnet.terrain import available, registered_terrains, resolve

    if args.terrain_cmd == "list":
        for name in available():
            print(name)
        for name in registered_terrains():
            print(f"{name}  (registered by a plugin)")
        print("random  (generated: --removed N --seed S)")
        print("random_heights  (generated: --removed N --seed S --height H)")
        return 0
    if args.terrain_cmd == "import":
        return _terrain_import(args)
    terrain = resolve(args.terrain, removed=args.removed, seed=args.seed, height_m=args.height)
    if args.terrain_cmd == "check":
        print(terrain.summary())
        return 0
    if args.terrain_cmd == "render":
        out = Path(args.out or f"{terrain.name}.png")
        feet_xy_base = registry.load_robot(args.robot).description.foot_nominal_base[:, :2]
        terrain.render_png(out, feet_xy_start=terrain.start_xy + feet_xy_base)
        print(f"wrote {out}")
        return 0
    if args.terrain_cmd == "save":
        out = Path(args.out)
        if out.exists() and not args.force:
            raise UserError(f"{out} exists; pass --force to overwrite it")
        terrain.save(out)
        print(f"wrote {out}")
        return 0
    raise AssertionError(args.terrain_cmd)


def _terrain_import(args: argparse.Namespace) -> int:
    from contactnet.terrain import SegmentConfig, import_terrain

    out = Path(args.out)
    if out.exists() and not args.force:
        raise UserError(f"{out} exists; pass --force to overwrite it")
    config = SegmentConfig(max_step_m=args.max_step, max_spread_m=args.max_spread, max_drop_m=args.max_drop,
                           min_width_m=args.min_width, max_roughness_m=args.max_roughness)
    terrain, report = import_terrain(args.source, resolution_m=args.resolution, z_scale=args.z_scale,
                                     origin_xy=args.origin, start_xy=args.start, goal_x=args.goal_x, config=config,
                                     name=args.name)
    terrain.save(out)
    for line in report.lines():
        print(line)
    print(f"wrote {out}; start ({terrain.start_xy[0]:.2f}, {terrain.start_xy[1]:.2f}) m, goal x {terrain.goal_x:.2f} m; "
          f"see it: contactnet terrain render {out}")
    return 0


__all__ = ["add_terrain_parser", "cmd_terrain"]
