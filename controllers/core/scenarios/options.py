"""The options the built-in scenarios share, declared once (name, flag, kind, help).

A scenario lists the ones its procedure takes (:attr:`ScenarioSpec.options`); ``mjchar run`` gets
one flag per option, refuses a flag the chosen scenario does not take, and parses and
range-checks the value by its kind. A new scenario may declare its own :class:`Option`.
"""

from __future__ import annotations

from ..limits import MAX_DURATION_S
from .registry import Option

DURATION = Option("duration", "--duration", "seconds",
                  "simulated seconds (default: per scenario; the clip for track/walk; a clip "
                  "that does not loop or a saved trajectory: at most its length)",
                  high=MAX_DURATION_S, metavar="T")
FORCE = Option("force", "--push", "newtons",
               "push force in N (push: required; random-push: default 10; track/walk and "
               "replays: one push while moving, at --push-time)", metavar="N")
DIRECTION = Option("direction", "--direction", "degrees",
                   "push direction in degrees from the facing direction (0 forward, 90 left, "
                   "180 backward, 270 right) or a name; default forward", metavar="DEG")
PUSH_DURATION = Option("push_duration", "--push-duration", "seconds",
                       "push length in s (default 0.2)", high=5.0, metavar="S")
PUSH_TIME = Option("push_time", "--push-time", "seconds",
                   "when the push starts, s (default 1)", metavar="S")
ALLOW_STEPS = Option("allow_steps", "--allow-steps", "switch",
                     "a push counts as survived even if a foot moved (stepping controllers)")
SEED = Option("seed", "--seed", "seed",
              "random seed: random-push's directions (default 0); walk and slopes: start "
              "walkers from their own start state perturbed from it (default: the standing "
              "pose at rest); track: start from the clip's first frame perturbed from it "
              "(joints N(0, 0.1 rad), root velocity N(0, 0.2 m/s); default: unperturbed)",
              metavar="N")
STEADY_WINDOW = Option("steady_window", "--steady-window", "seconds",
                       "walk: also report the steady speed over the last S seconds",
                       high=MAX_DURATION_S, metavar="S")
MAX_FORCE = Option("max_force", "--max-force", "newtons",
                   "push-search: the force grid's cap in N (default 500)", metavar="N")
TOLERANCE = Option("tolerance", "--tolerance", "newtons",
                   "push-search: the force grid's step in N (default 25)", metavar="N")
PHASES = Option("phases", "--phases", "count",
                "push-search: phases of the stride (walkers) or moments (standing) pushed at "
                "(default 4)", high=64, metavar="K")
SEEDS = Option("seeds", "--seeds", "count",
               "push-search: seeds 0..S-1 of the start perturbation (default 2)", high=100,
               metavar="S")
SLOPE = Option("degrees", "--slope", "number",
               "slopes: the slope in degrees, positive uphill (default 5)", high=44.0,
               metavar="DEG")
DISTANCE = Option("distance", "--distance", "metres",
                  "slopes: the distance to cover along the slope, m (default 20, at most 1000)",
                  high=1000.0, metavar="M")

#: the push while tracking or walking (``track``, ``walk``): its details need ``force``
PUSH_WHILE_MOVING = (FORCE, DIRECTION, PUSH_TIME, PUSH_DURATION)
