"""mjchar's bundled data (no code): the default humanoid ``mjcf/humanoid.xml``, its motions
``motions/*.bvh`` and saved trajectories ``trajectories/*.npz``.

The files ship as package data in the wheel; :mod:`bvh.assets` finds them with
``importlib.resources``, so an installed mjchar needs no source checkout.
"""

#: marks this package as mjchar's (another top-level ``assets`` package could shadow it)
MJCHAR_ASSETS = True
