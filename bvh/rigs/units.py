"""Units and up-axis: detection from a skeleton's layout, and conversion of motions.

A BVH file does not say its units or which axis is up; these guesses use the rest pose of a
human-like skeleton (standing height, head above feet).

**Units from anatomy** (:func:`unit_from_stature`): the body's stature in file units (measured by
the converter on its canonical standing rest, cross-checked with the leg bones) gives the
*anatomical* scale, the metres per unit that would make it :data:`TYPICAL_HEIGHT_M` tall. It is
snapped to the known unit (:data:`KNOWN_UNITS`: m, dm, cm, mm, in, ft and the CMU ASF unit of
1/0.45 inch) that puts the body inside :data:`HEIGHT_RANGE_M`; when two do (decimetres and the
CMU unit are a factor 1.77 apart), the one that makes it an adult (:data:`ADULT_RANGE_M`), then
a common unit before a rare one (:data:`RARE_UNITS`), then the one nearest the typical height
in log scale. When none fits, the anatomical scale itself is used and the guess says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjchar.bvh.errors import SkeletonError
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.rotations import from_rotation, quat_conj, quat_mul, quat_rotate, to_rotation

#: metres per unit of the CMU motion-capture ASF files: lengths are in units of 1/0.45 inch
CMU_UNIT = 0.0254 / 0.45
#: metres per unit for the unit names accepted by :func:`unit_scale`
UNIT_SCALES = {"m": 1.0, "dm": 0.1, "cm": 0.01, "mm": 0.001, "in": 0.0254, "inch": 0.0254,
               "ft": 0.3048, "foot": 0.3048, "feet": 0.3048, "cmu": CMU_UNIT}
#: the units a body's anatomical scale snaps to (name -> metres per unit)
KNOWN_UNITS = {"m": 1.0, "dm": 0.1, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048,
               "cmu": CMU_UNIT}
#: metres: the stature the anatomical scale gives a body, and the range a known unit must put
#: it in to be chosen (outside it the converter warns)
TYPICAL_HEIGHT_M = 1.7
HEIGHT_RANGE_M = (1.0, 2.3)
#: metres: an adult's stature; when two known units put a body in :data:`HEIGHT_RANGE_M`, the
#: one that makes it an adult wins
ADULT_RANGE_M = (1.4, 2.1)
#: units seldom written (Blender scenes at 0.1 m per unit): behind the common ones in a tie
RARE_UNITS = frozenset({"dm"})
#: the file axes an up axis may be (a leading ``-``: the axis points down, as in an Azure Kinect
#: export whose +Y is down)
AXIS_VECTORS = {"x": np.eye(3)[0], "y": np.eye(3)[1], "z": np.eye(3)[2],
                "-x": -np.eye(3)[0], "-y": -np.eye(3)[1], "-z": -np.eye(3)[2]}


def axis_index(up: str) -> int:
    """``0``, ``1`` or ``2``: the file axis of a signed axis name (``"-y"`` -> ``1``)."""
    return "xyz".index(up[-1])


def unit_scale(unit: str) -> float:
    """Metres per ``unit`` (``"m"``, ``"dm"``, ``"cm"``, ``"mm"``, ``"in"``, ``"ft"``,
    ``"cmu"``)."""
    try:
        return UNIT_SCALES[unit.lower()]
    except KeyError:
        raise SkeletonError(
            f"unknown unit {unit!r}; expected one of {sorted(UNIT_SCALES)}") from None


def _extent_points(skeleton: Skeleton) -> np.ndarray:
    pts = skeleton.rest_positions()
    if skeleton.n_end_sites:
        pts = np.concatenate([pts, skeleton.rest_end_sites()])
    return pts


def guess_up_axis(skeleton: Skeleton) -> str:
    """``"y"`` or ``"z"`` (or ``"x"``): the axis along which the rest pose is tallest.

    A standing T-pose is taller than it is deep; arms may make it as wide as tall, so the two
    horizontal candidates are told apart by depth: the axis with the largest extent among
    those orthogonal to the arm span is up.
    """
    pts = _extent_points(skeleton)
    ext = pts.max(axis=0) - pts.min(axis=0)
    order = np.argsort(ext)[::-1]
    # the smallest extent is depth (front-back); of the other two, prefer the one in which
    # the root lies between the extremes asymmetrically (legs longer below than head above)
    a, b = order[0], order[1]
    root = skeleton.rest_positions()[0]

    def asym(ax: int) -> float:
        lo, hi = pts[:, ax].min(), pts[:, ax].max()
        span = max(hi - lo, 1e-12)
        return abs((root[ax] - lo) - (hi - root[ax])) / span  # arms are symmetric, legs/head not

    up = a if asym(a) >= asym(b) else b
    return "xyz"[int(up)]


def guess_unit_scale(skeleton: Skeleton) -> float:
    """Metres per file unit guessed from the standing height of the rest pose
    (:func:`unit_from_stature`): heights near 1.7 are metres, near 170 centimetres, near 67
    inches, near 30 CMU ASF units, near 1700 millimetres."""
    pts = _extent_points(skeleton)
    ax = "xyz".index(guess_up_axis(skeleton))
    height = float(pts[:, ax].max() - pts[:, ax].min())
    if height <= 0:
        raise SkeletonError("cannot guess units: the skeleton has no height (all joints coincide)")
    return unit_from_stature(height).scale


@dataclass(frozen=True)
class UnitGuess:
    """A unit guessed from a body's size.

    Attributes:
        name: the known unit snapped to (a key of :data:`KNOWN_UNITS`), or ``None`` when none
            puts the body in :data:`HEIGHT_RANGE_M` (``scale`` is then ``anatomical``).
        scale: metres per file unit.
        anatomical: metres per file unit making the body :data:`TYPICAL_HEIGHT_M` tall.
        stature: the body's stature in file units.
    """

    name: str | None
    scale: float
    anatomical: float
    stature: float

    @property
    def height_m(self) -> float:
        """The stature in metres at :attr:`scale`."""
        return self.stature * self.scale


def unit_from_stature(stature: float) -> UnitGuess:
    """The unit of a body ``stature`` file units tall: the known unit putting it inside
    :data:`HEIGHT_RANGE_M` (nearest :data:`TYPICAL_HEIGHT_M` in log scale when two do), else
    the anatomical scale (module docstring)."""
    stature = float(stature)
    if not (np.isfinite(stature) and stature > 0):
        raise SkeletonError("cannot guess units: the skeleton has no height (all joints coincide)")
    lo, hi = HEIGHT_RANGE_M
    fits = [u for u, s in KNOWN_UNITS.items() if lo <= stature * s <= hi]
    anatomical = TYPICAL_HEIGHT_M / stature
    if not fits:
        return UnitGuess(None, anatomical, anatomical, stature)

    def rank(u: str) -> tuple:
        h = stature * KNOWN_UNITS[u]
        adult = ADULT_RANGE_M[0] <= h <= ADULT_RANGE_M[1]
        return (not adult, u in RARE_UNITS, abs(np.log(h / TYPICAL_HEIGHT_M)))

    name = min(fits, key=rank)
    return UnitGuess(name, KNOWN_UNITS[name], anatomical, stature)


def unit_name(scale: float) -> str | None:
    """The known unit of ``scale`` metres per unit (``0.0254`` -> ``"in"``), or ``None``."""
    for name, s in KNOWN_UNITS.items():
        if abs(scale - s) <= 1e-9 * s:
            return name
    return None


def unit_for_height(height: float) -> float:
    """Metres per unit for a figure ``height`` file units tall (:func:`unit_from_stature`)."""
    return unit_from_stature(height).scale


def up_axis_rotation(from_up: str, to_up: str = "z") -> np.ndarray:
    """wxyz quaternion ``(4,)`` of the change of basis taking ``from_up`` to ``to_up``.

    Y-up to Z-up is +90 degrees about X (Y -> Z, Z -> -Y), which also keeps a character facing
    +Z in Y-up facing -Y in Z-up; callers that need a particular facing rotate further. A
    negative axis (``"-y"``) turns by 180 degrees about a perpendicular axis where needed.
    """
    a, b = AXIS_VECTORS[from_up.lower()], AXIS_VECTORS[to_up.lower()]
    if np.allclose(a, b):
        return np.array([1.0, 0.0, 0.0, 0.0])
    if np.allclose(a, -b):  # opposite: half a turn about another axis
        other = np.eye(3)[(axis_index(from_up.lower()) + 1) % 3]
        return np.array([0.0, *other])
    axis = np.cross(a, b)
    axis /= np.linalg.norm(axis)
    return np.array([np.cos(np.pi / 4), *(np.sin(np.pi / 4) * axis)])


def transform_motion(motion: Motion, scale: float = 1.0,
                     rotation: np.ndarray | None = None) -> Motion:
    """Express ``motion`` in other units and axes: new world = ``scale * R * old world``.

    Offsets, translations and end sites are scaled and rotated; local rotations are conjugated
    (``R q R^-1``), so forward kinematics of the result equals the old one transformed.
    ``rotation``: wxyz quaternion ``(4,)`` or ``None`` for no rotation.
    """
    q = np.array([1.0, 0, 0, 0]) if rotation is None else np.asarray(rotation, dtype=float)
    sk = motion.skeleton.copy()
    sk.offsets = scale * quat_rotate(q, sk.offsets)
    sk.end_site_offsets = scale * quat_rotate(q, sk.end_site_offsets)
    pos = scale * quat_rotate(q, motion.local_positions)
    rot = quat_mul(quat_mul(q, motion.rotations), quat_conj(q))
    return Motion(sk, motion.frame_time, pos, rot)


def to_metres(motion: Motion, unit: str | float | None = None, up: str | None = None,
              to_up: str = "y") -> Motion:
    """Motion in metres with ``to_up`` as the up axis (units/up guessed when ``None``)."""
    scale = guess_unit_scale(motion.skeleton) if unit is None else (
        unit_scale(unit) if isinstance(unit, str) else float(unit))
    up = up or guess_up_axis(motion.skeleton)
    return transform_motion(motion, scale, up_axis_rotation(up, to_up))


__all__ = ["unit_scale", "guess_up_axis", "guess_unit_scale", "up_axis_rotation",
           "transform_motion", "to_metres", "unit_for_height", "unit_from_stature", "unit_name",
           "axis_index", "AXIS_VECTORS",
           "UnitGuess", "KNOWN_UNITS", "CMU_UNIT", "from_rotation", "to_rotation"]
