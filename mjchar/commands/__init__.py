"""``mjchar`` subcommands: one module each, exposing ``HELP`` and ``register(subparsers)``.

``HELP`` is the subcommand's line in ``mjchar --help``; ``register`` adds its parser and sets
``func`` (taking the parsed args, returning the exit status), and is called only when the
command line names the subcommand (:func:`mjchar.cli.build_parser`). Keep heavy imports inside
``register`` and ``func``: importing a command module must not import the controllers.
"""

#: modules (relative to this package) whose subcommands ``mjchar`` offers, in help order
COMMANDS = ["info", "convert", "run", "params", "calibrate", "gait", "samcon", "trajopt", "learn",
            "bench"]
