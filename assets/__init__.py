"""mjchar's bundled data (no code): the default humanoid ``mjcf/humanoid.xml``, its motions
``motions/*.bvh`` and saved trajectories ``trajectories/*.npz``.

The files ship as package data in the wheel; :mod:`mjchar.bvh.bundled.assets` finds them with
``importlib.resources``, so an installed mjchar needs no source checkout.
"""
