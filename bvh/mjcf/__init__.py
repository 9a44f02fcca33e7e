"""BVH -> MJCF conversion: a simulated humanoid from any BVH skeleton.

    import mjchar.bvh.mjcf
    converted = mjchar.bvh.mjcf.convert("walk.bvh", total_mass=70.0, joint_model="hinge")
    converted.save("walk.xml")
    model = converted.compile()                     # mujoco.MjModel
    info = mjchar.bvh.mjcf.ModelInfo.from_model(model)     # the joint map kept in the model

What every converted model guarantees is written down in docs/model-contract.md; how it is built
(geometry, masses, gains, contacts) in docs/converter.md.
"""

from mjchar.bvh.mjcf.builder import (
           JOINT_MODELS,
           ConvertedModel,
           convert,
           default_drop,
           default_fuse,
)
from mjchar.bvh.mjcf.info import ConversionError, JointInfo, ModelInfo

__all__ = ["convert", "ConvertedModel", "ModelInfo", "JointInfo", "ConversionError",
           "JOINT_MODELS", "default_drop", "default_fuse"]
