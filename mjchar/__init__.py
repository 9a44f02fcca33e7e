"""mjchar: the application layer on top of the library packages.

``bvh`` (kinematics, the BVH -> MJCF converter) <- ``controllers`` (dynamics) <- ``envs``
(Gymnasium) <- ``mjchar``: the ``mjchar`` command line (:mod:`mjchar.cli`, one module per
subcommand in :mod:`mjchar.commands`), the benchmark (:mod:`mjchar.bench`), performance
measurement (:mod:`mjchar.perf`) and video rendering (:mod:`mjchar.render`).

``python -m mjchar ...`` is the same as the ``mjchar`` console script.
"""

import os
import sys

if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY")
                                             or os.environ.get("WAYLAND_DISPLAY")):
    # headless: render with EGL. MuJoCo picks its OpenGL backend when it is first imported,
    # and the CLI imports the controllers (hence MuJoCo) to list them, so decide it here.
    os.environ.setdefault("MUJOCO_GL", "egl")
