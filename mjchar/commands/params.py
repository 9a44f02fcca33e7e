"""``mjchar params CONTROLLER``: every tunable ``mjchar run CONTROLLER --param NAME=VALUE``
takes, with its type, unit, accepted range, default and meaning, read from the controller's
parameter declarations (the same ones that check ``--param`` values)."""

from __future__ import annotations

import argparse

from . import command_parser


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``params`` subcommand to ``mjchar``'s subparsers."""
    from mjchar.controllers import registry

    with_params = [s.name for s in registry.specs() if s.tunables is not None]
    p = command_parser(
        sub, "params",
        description="List every tunable of a controller that mjchar run takes as --param "
                    "NAME=VALUE: its type, unit, accepted range, default and meaning. "
                    f"Controllers with tunables: {', '.join(with_params)}. Ranges of "
                    "dimensional parameters are for the body the defaults were tuned on (the "
                    "bundled humanoid); the walkers carry them to another body by dynamic "
                    "similarity.")
    p.add_argument("controller", choices=with_params, metavar="CONTROLLER",
                   help="one of: " + ", ".join(with_params))
    p.add_argument("--gait", metavar="NAME",
                   help="simbicon: show the defaults of this gait (default walk)")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: {controller, tunables: [{name, type, unit, "
                        "range, default, meaning}]}")
    p.set_defaults(func=main)


def _shown(value) -> str:
    import json

    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, tuple | list):
        return "[" + ", ".join(_shown(v) for v in value) + "]"
    if isinstance(value, dict):
        return json.dumps(value, separators=(",", ":"))
    return str(value)


def main(args: argparse.Namespace) -> int:
    """Print the table (or one JSON object)."""
    import json

    from mjchar.bvh.errors import MjcharError
    from mjchar.controllers import registry

    spec = registry.get(args.controller)
    options = {}
    if args.gait is not None:
        if "gait" not in spec.options:
            raise MjcharError(f"--gait applies to controllers with gaits (simbicon), not to "
                              f"{spec.name}")
        options["gait"] = args.gait
    rows = [t.row() for t in spec.tunables(**options)]
    if args.json:
        print(json.dumps({"controller": spec.name, "tunables": rows}))
        return 0
    print(f"{spec.name}: {len(rows)} tunables; set one with mjchar run {spec.name} --param "
          f"NAME=VALUE (VALUE read as JSON, else as text)")
    head = ("NAME", "TYPE", "UNIT", "RANGE", "DEFAULT", "MEANING")
    table = [head] + [(r["name"], r["type"], r["unit"], r["range"], _shown(r["default"]),
                       r["meaning"]) for r in rows]
    # columns as wide as their longest cell, up to 28 characters (a longer default overflows)
    widths = [min(max(len(row[i]) for row in table), 28) for i in range(len(head) - 1)]
    for row in table:
        print("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=False)) + "  " + row[-1])
    return 0
