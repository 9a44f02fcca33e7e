"""mjchar: physics-based character control on MuJoCo.

One import namespace, in layers (each imports only from those below it):

- :mod:`mjchar.bvh`: everything kinematic (BVH files, skeletons, the BVH -> MJCF converter,
  reference motions), no simulation;
- :mod:`mjchar.controllers`: everything dynamic (the Character, the controllers, scenarios and
  the run builder);
- :mod:`mjchar.envs`: Gymnasium environments, registered as ``mjchar/...``;
- the application: the ``mjchar`` command line (:mod:`mjchar.cli`, one module per subcommand in
  :mod:`mjchar.commands`), the benchmark (:mod:`mjchar.bench`), measurement
  (:mod:`mjchar.perf`) and video rendering (:mod:`mjchar.render`);
- :mod:`mjchar.assets`: the bundled data (humanoid, motions, trajectories), no code.

``import mjchar`` is light: it imports neither Gymnasium nor the controllers, and
``gymnasium.make("mjchar/...")`` works after it (the ids are registered once Gymnasium is
imported: :mod:`mjchar.gym_ids`). ``python -m mjchar ...`` is the ``mjchar`` command.
"""

import os
import sys
from importlib.metadata import PackageNotFoundError, version

if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY")
                                             or os.environ.get("WAYLAND_DISPLAY")):
    # headless: render with EGL. MuJoCo picks its OpenGL backend when it is first imported,
    # so decide it before anything imports MuJoCo.
    os.environ.setdefault("MUJOCO_GL", "egl")

try:
    __version__ = version("mjchar")
except PackageNotFoundError:  # a source tree that was never installed
    __version__ = "0+unknown"


from mjchar.gym_ids import register_with_gymnasium as _register  # noqa: E402

_register()  # the mjchar/... ids, when Gymnasium is (or once it is) imported
