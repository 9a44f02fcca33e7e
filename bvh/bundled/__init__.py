"""The project's own material, made from its skeleton and known clips.

- :mod:`~mjchar.bvh.bundled.assets`: where the bundled files are (the humanoid, motions,
  trajectories) and how they are regenerated (``python -m mjchar.bvh.bundled.assets``).
- :mod:`~mjchar.bvh.bundled.humanoid_skeleton`: the 20-joint skeleton of the bundled humanoid.
- :mod:`~mjchar.bvh.bundled.authored`: the bundled idle and walk, authored from key poses.
- :mod:`~mjchar.bvh.bundled.zoo`: the rig zoo: real-world BVH layouts generated from known clips.
"""
