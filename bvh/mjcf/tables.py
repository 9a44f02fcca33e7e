"""Per-role tables of the converter: mass fractions, capsule radii, Euler orders, joint ranges,
PD gains, torque limits and armature.

Axes are the MuJoCo model's: x forward, y to the character's left, z up (at rest every body
frame is world-aligned). Ranges are given for the *left* side in degrees; the right side mirrors
them (rotations about x and z change sign, about y they do not, see :func:`mirrored_range`).

Sources: segment mass fractions from de Leva (1996), "Adjustments to Zatsiorsky-Seluyanov's
segment inertia parameters" (male values, % of body mass); gains from the DeepMimic humanoid
(Peng et al. 2018) rescaled to a 70 kg character; ranges are textbook ranges of motion, widened
so that every pose of the project's reference clips stays inside them (tests check this).
"""

from __future__ import annotations

#: reference body height (m) the lengths below are given for; they scale with the skeleton
REFERENCE_HEIGHT = 1.75
#: reference mass (kg) the gains below are given for
REFERENCE_MASS = 70.0

#: de Leva (1996) male segment masses in % of body mass (limb groups are per side)
GROUP_FRACTION = {
    "trunk": 43.46,
    "head_neck": 6.94,
    "upper_arm": 2.71,
    "forearm": 1.62,
    "hand": 0.61,
    "thigh": 14.16,
    "shank": 4.33,
    "foot": 1.37,
}

#: which mass group a body of a given role belongs to (``None``: mass from geometry)
ROLE_GROUP = {
    "pelvis": "trunk", "spine": "trunk", "clavicle": "trunk",
    "neck": "head_neck", "head": "head_neck",
    "shoulder": "upper_arm", "elbow": "forearm", "wrist": "hand", "hand": "hand",
    "hip": "thigh", "knee": "shank", "ankle": "foot", "toe": "foot",
    "face": "head_neck", "toes": "foot",
    "unknown": None, "end": None, "twist": None,
}

#: fixed shares of the trunk group (% of body mass): the lower trunk (pelvis, de Leva's LPT)
#: and each clavicle; the spine bodies share what is left by volume
TRUNK_SHARE = {"pelvis": 11.17, "clavicle": 1.5}

#: density (kg/m^3) used to weigh bodies of unknown role before the whole is scaled
DENSITY = 1000.0

#: capsule radius (m, at REFERENCE_HEIGHT) of the segment a body of this role carries;
#: for feet and toes, the half-width of the box
RADIUS = {
    "pelvis": 0.085, "spine": 0.09, "neck": 0.05, "head": 0.095, "clavicle": 0.05,
    "shoulder": 0.045, "elbow": 0.037, "wrist": 0.032, "hand": 0.012,
    "hip": 0.07, "knee": 0.05, "ankle": 0.045, "toe": 0.045, "unknown": 0.035, "end": 0.03,
    "face": 0.01, "toes": 0.01, "twist": 0.035,
}

#: spine segments are two capsules side by side: lateral offset and radius, times the spine radius
TRUNK_PAIR_OFFSET = 0.6
TRUNK_PAIR_RADIUS = 0.85

#: contact softness (time constant s, damping ratio) of every geom: stiffer than MuJoCo's default
#: 0.02 s so that a falling body sinks less than 2 cm into the floor; >= 2 time steps
SOLREF = (0.01, 1.0)

#: hinge order (outer to inner) of a 3-DoF joint, chosen so that the middle axis is the one with
#: the smallest range for that role (it must stay away from +-90 degrees): legs, spine and head
#: flex about y first; arms (lateral in the rest pose) swing about z first and twist (y) in the
#: middle only as far as the arm twists.
EULER_ORDER = {
    "pelvis": "yxz", "spine": "yxz", "neck": "yxz", "head": "yxz",
    "hip": "yxz", "knee": "yxz", "ankle": "yxz", "toe": "yxz",
    "clavicle": "zyx", "shoulder": "zyx", "elbow": "zyx", "wrist": "zyx", "hand": "zyx",
    "unknown": "zyx", "end": "zyx", "face": "zyx", "toes": "yxz", "twist": "zyx",
}

#: anatomical ranges (degrees, left side) per axis for the ``hinge`` joint model; knees and
#: elbows (one hinge) use :data:`FLEXION_RANGE` instead
RANGE_DEG = {
    "pelvis": {"x": (-40, 40), "y": (-45, 75), "z": (-50, 50)},
    "spine": {"x": (-40, 40), "y": (-45, 75), "z": (-50, 50)},
    "neck": {"x": (-50, 50), "y": (-60, 80), "z": (-80, 80)},
    "head": {"x": (-50, 50), "y": (-60, 80), "z": (-80, 80)},
    "clavicle": {"x": (-40, 40), "y": (-35, 35), "z": (-40, 40)},
    # left arm along +y: arm down is -x, arm forward is -z
    "shoulder": {"x": (-110, 160), "y": (-100, 100), "z": (-140, 70)},
    "elbow": {"x": (-40, 40), "y": (-100, 100), "z": (-160, 15)},
    "wrist": {"x": (-80, 80), "y": (-90, 90), "z": (-80, 80)},
    "hand": {"x": (-90, 90), "y": (-90, 90), "z": (-90, 90)},
    # left leg along -z: leg forward (flexion) is -y, leg outward (abduction) is +x
    "hip": {"x": (-40, 70), "y": (-130, 45), "z": (-60, 60)},
    "knee": {"x": (-40, 40), "y": (-15, 160), "z": (-40, 40)},
    # plantar flexion (toes down) is +y
    "ankle": {"x": (-45, 45), "y": (-50, 65), "z": (-45, 45)},
    "toe": {"x": (-20, 20), "y": (-80, 50), "z": (-20, 20)},
    "unknown": {"x": (-170, 170), "y": (-170, 170), "z": (-170, 170)},
    "end": {"x": (-170, 170), "y": (-170, 170), "z": (-170, 170)},
    "face": {"x": (-90, 90), "y": (-90, 90), "z": (-90, 90)},
    "toes": {"x": (-20, 20), "y": (-80, 50), "z": (-20, 20)},
    "twist": {"x": (-170, 170), "y": (-170, 170), "z": (-170, 170)},
}

#: range (degrees) of the single flexion hinge of knees and elbows, flexion positive
FLEXION_RANGE = {"knee": (-15.0, 160.0), "elbow": (-15.0, 160.0)}

#: (kp N m/rad, kd N m s/rad, torque limit N m, subtree mass fraction) for a 70 kg character;
#: gains and limits scale with the mass the joint actually moves (its subtree) over the
#: reference subtree mass ``fraction * total``
GAINS = {
    "pelvis": (1000.0, 100.0, 300.0, 0.60),
    "spine": (1000.0, 100.0, 300.0, 0.45),
    "neck": (200.0, 20.0, 60.0, 0.0694),
    "head": (150.0, 15.0, 50.0, 0.0694),
    "clavicle": (500.0, 50.0, 120.0, 0.065),
    "shoulder": (400.0, 40.0, 120.0, 0.0494),
    "elbow": (300.0, 30.0, 80.0, 0.0223),
    "wrist": (80.0, 8.0, 30.0, 0.0061),
    "hand": (20.0, 2.0, 10.0, 0.002),
    "hip": (600.0, 60.0, 250.0, 0.1986),
    "knee": (500.0, 50.0, 200.0, 0.0570),
    "ankle": (400.0, 40.0, 150.0, 0.0137),
    "toe": (100.0, 10.0, 40.0, 0.0030),
}
#: gains of joints of unknown role: kp per kg of subtree mass (kd = kp/10, limit = kp * 0.3 rad)
UNKNOWN_KP_PER_KG = 40.0
#: bounds of the mass scaling factor applied to the table gains
GAIN_SCALE_BOUNDS = (0.2, 5.0)

#: joint armature (kg m^2, reflected rotor inertia) per role; it keeps light links stable under
#: explicit (Python-side) PD, see REFERENCE.md
ARMATURE = {
    "pelvis": 0.05, "spine": 0.05, "hip": 0.05, "knee": 0.05,
    "neck": 0.03, "head": 0.03, "clavicle": 0.03, "shoulder": 0.03, "elbow": 0.03,
    "ankle": 0.03, "wrist": 0.02, "toe": 0.02, "hand": 0.01, "unknown": 0.03, "end": 0.01,
    "face": 0.01, "toes": 0.01, "twist": 0.03,
}

#: passive joint damping (N m s/rad) per role: physiological joint viscosity, small next to the
#: actuators' kv; it lets a passive ragdoll come to rest (an undamped hand rolls on the floor
#: forever). MuJoCo integrates it implicitly, so it never costs stability.
DAMPING = {
    "pelvis": 1.0, "spine": 1.0, "hip": 1.0, "knee": 1.0,
    "neck": 0.5, "head": 0.5, "clavicle": 0.5, "shoulder": 0.5, "elbow": 0.5, "ankle": 0.5,
    "wrist": 0.2, "toe": 0.2, "hand": 0.1, "unknown": 0.5, "end": 0.1,
    "face": 0.1, "toes": 0.1, "twist": 0.5,
}

#: default simulation time step (s): native PD (position actuators, implicitfast) is stable here
#: for every table gain, and explicit PD from Python is stable with the armature above
TIMESTEP = 0.002

#: floor friction (sliding, torsional, rolling)
FRICTION = (1.0, 0.005, 0.0001)


def mirrored_range(rng: tuple[float, float], axis: str, side: str | None) -> tuple[float, float]:
    """Range for ``side`` from a left-side range: mirroring through the sagittal (xz) plane
    negates rotations about x and z and keeps those about y."""
    lo, hi = rng
    if side == "right" and axis in ("x", "z"):
        return (-hi, -lo)
    return (lo, hi)
