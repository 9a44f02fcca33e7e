"""``mjchar`` subcommands: one module each, exposing ``register(subparsers)``.

``register`` adds the subcommand's parser and sets ``func`` (taking the parsed args, returning the
exit status). Keep heavy imports inside ``func`` so ``mjchar --help`` stays fast.
"""

#: modules (relative to this package) whose subcommands ``mjchar`` offers, in help order
COMMANDS = ["info", "convert", "run", "params", "calibrate", "gait", "samcon", "trajopt", "learn",
            "bench"]
