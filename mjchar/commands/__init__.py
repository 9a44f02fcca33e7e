"""``mjchar`` subcommands: one module each, exposing ``register(subparsers)``.

:data:`COMMANDS` names them with their lines in ``mjchar --help``; a module's ``register`` adds
its parser and sets ``func`` (taking the parsed args, returning the exit status), and is called
only when the command line names the subcommand (:func:`mjchar.cli.build_parser`): the other
modules are not imported. Keep heavy imports inside ``register`` and ``func``.
"""

#: the subcommands in help order, each with its line in ``mjchar --help`` (a module of this
#: package each)
COMMANDS = {
    "info": "summarise a BVH file (joints, frames, units, axes, the joint roles and the body the "
            "converter would build)",
    "convert": "convert a BVH skeleton into a MuJoCo humanoid (MJCF)",
    "run": "run a controller in a scenario (stand, push, track, ...) and report metrics",
    "params": "list a controller's tunables (--param NAME=VALUE of mjchar run)",
    "calibrate": "fit the walkers (ipm, simbicon) to a converted body, ahead of its runs",
    "gait": "gait statistics of a walker or a clip against reference clips",
    "samcon": "reconstruct a motion clip with SAMCON (open-loop PD targets, no root force)",
    "trajopt": "CMA-ES trajectory optimisation (clip tracking or a vertical jump)",
    "learn": "learn a tracking policy from the MPC (DAgger; needs the rl extra)",
    "bench": "benchmark every controller in every scenario; table, JSON, plots",
}


def command_parser(sub, name: str, description: str | None = None):
    """The subcommand ``name``'s parser in ``mjchar``'s subparsers ``sub``, with its line of
    help from :data:`COMMANDS` (what every module's ``register`` starts with)."""
    return sub.add_parser(name, help=COMMANDS[name], description=description)
