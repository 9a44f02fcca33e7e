"""The converter's step 0: a real export made into a standing rig in world axes.

:func:`prepare` takes the file's clip (or bare skeleton) and, without moving any joint
(:mod:`mjchar.bvh.rigs.layouts`):

1. **folds a static chain above the pelvis** (``Reference``, ``root``, ``joint_Root``: every
   joint above the joint where the legs part has a single child): the pelvis becomes the root
   and carries its global transform per frame; a constant rotation of the chain (a Z-up
   armature under a Y-up world) is folded into the rest pose;
2. **takes bones from translation channels** of non-root joints: the mean over the clip is the
   bone; a joint whose translation varies more than :data:`BONE_TOLERANCE_M` is named in a
   warning with its variation in mm;
3. **finds the up axis and the roles**: up is the file axis along the legs (hips above ankles)
   over the clip (the rest pose without one; the clip wins because it is what gravity saw), the
   roles from names, else from the skeleton's geometry and the clip's motion
   (:func:`mjchar.bvh.rigs.naming.recognise`), with the user's role map; without one, a
   skeleton that is not a two-legged humanoid (three or more limbs on the floor, a trunk not
   above the legs or not upright: :mod:`mjchar.bvh.rigs.anatomy`) is refused in one line; the
   essential roles (pelvis, hips, knees, ankles) are checked: one :class:`ConversionError`
   that lists what is missing and shows how to map it (no legs at all: "not a humanoid");
4. **gives the skeleton its canonical rest** (:func:`mjchar.bvh.rigs.canonical.canonical_rest`:
   standing, legs straight down, arms in a T-pose, the rest of the file's shape kept where it
   is a human one), built from the skeleton and its roles, not from a frame of the clip;
5. **guesses the unit from anatomy** (unless given): the stature of the canonical rest (the
   leg bones' when it disagrees with them) snapped to a known unit, or the anatomical scale
   when none fits (:func:`mjchar.bvh.rigs.units.unit_from_stature`); glitch frames of the clip
   are flagged in a warning (:func:`mjchar.bvh.rigs.glitches.find_glitches`).

What was done is kept in the model's metadata as ``rig``
(:func:`mjchar.bvh.rigs.layouts.apply_record`), so
:class:`mjchar.bvh.reference.reference_motion.ReferenceMotion` replays the file's own clip through
the same steps.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.mjcf.info import ConversionError
from mjchar.bvh.mjcf.roles import ESSENTIAL_ROLES, check_roles, missing_roles_error
from mjchar.bvh.rigs import anatomy, structure
from mjchar.bvh.rigs.canonical import CanonicalRest, canonical_rest
from mjchar.bvh.rigs.glitches import find_glitches
from mjchar.bvh.rigs.layouts import (
    bones_from_channels,
    fold_record,
    fold_root,
    rerest,
    static_chain_above,
)
from mjchar.bvh.rigs.naming import Clip, Recognition, recognise
from mjchar.bvh.rigs.units import (
    AXIS_VECTORS,
    UnitGuess,
    axis_index,
    guess_up_axis,
    unit_from_stature,
    unit_name,
)

#: metres: a non-root translation channel varying more than this from its mean is warned about
BONE_TOLERANCE_M = 0.001
#: the largest extent (m) of a rest pose the converter builds a body from
MAX_SPAN_M = 100.0
#: hip-to-ankle length (thigh + shank bones) as a fraction of the standing height
LEG_FRACTION = 0.49
#: degrees: leg bones within this of their mean direction count as a standing leg
STRAIGHT_LEG_DEG = 35.0


@dataclass
class Prepared:
    """A rig ready for conversion (see the module docstring).

    Attributes:
        motion: the normalised clip (file units and axes), or ``None`` for a bare skeleton.
        skeleton: the normalised skeleton (its rest the canonical rest).
        scale: metres per file unit; ``up``: the file's up axis.
        rec: the roles.
        record: the ``rig`` metadata (``{}`` when the file needed nothing).
        warnings: what was done and what looks wrong.
        unit: how the unit was guessed (``None`` when it was given).
        canonical: the canonical rest (what moved, what was re-aimed).
        stature: the canonical rest's stature in file units (its height without the sole).
    """

    motion: Motion | None
    skeleton: Skeleton
    scale: float
    up: str
    rec: Recognition
    record: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    unit: UnitGuess | None = None
    canonical: CanonicalRest | None = None
    stature: float = 0.0


def prepare(motion: Motion | None, skeleton: Skeleton, unit: float | None = None,
            up_axis: str | None = None, roles: dict | None = None) -> Prepared:
    """Normalise a rig for conversion (steps 1-5 of the module docstring)."""
    roles = roles or {}
    check_roles(roles, skeleton.names, "the roles file")
    has_motion = motion is not None and motion.n_frames > 0
    work = motion if has_motion else Motion.rest(skeleton)
    clip = Clip.of(work) if has_motion else None
    warns: list[str] = []
    record: dict = {}
    given_up = AXIS_VECTORS[up_axis] if up_axis else None

    # 1. a static chain above the pelvis
    work, clip = _fold_static_root(work, clip, has_motion, given_up, roles, record, warns)

    # 2. bones from translation channels
    variation: dict[str, float] = {}
    if any(work.skeleton.has_position_channels()[1:]):
        work, variation = bones_from_channels(work)
        record["bones"] = True
        if has_motion:
            clip = Clip.of(work)

    # 3. the up axis and the roles
    sk = work.skeleton
    up, rec = _up_and_roles(sk, up_axis, given_up, roles, clip)
    _check_essential_roles(rec, skeleton.names, roles)

    # 4. the canonical rest
    can = canonical_rest(sk, rec, up, clip)
    if can.rest is not None:
        work = rerest(work, can.rest)
        sk = work.skeleton
        record["rest"] = {n: [float(x) for x in q] for n, q in zip(sk.names, can.rest,
                                                                      strict=True)
                          if not np.array_equal(q, [1.0, 0.0, 0.0, 0.0])}
        rec = recognise(sk, AXIS_VECTORS[up], roles, clip)
        warns += _rest_notes(can)

    # 5. the unit from anatomy
    stature = _stature(sk, rec, up)
    scale, guess = _unit_scale(stature, unit, warns)
    _check_span(sk, scale)
    if has_motion:
        glitches = find_glitches(work, scale)
        if glitches:
            warns.append(f"glitch frames: {glitches.describe()}; trackers repair short runs "
                         "by interpolation and refuse long ones (the clip is conditioned before "
                         "tracking)")
    noisy = {n: v * scale * 1000.0 for n, v in variation.items() if v * scale > BONE_TOLERANCE_M}
    if noisy:
        warns.append("translation channels vary (the mean is the bone): "
                     + ", ".join(f"{n} by {v:.1f} mm" for n, v in noisy.items()))
    return Prepared(work if has_motion else None, sk, scale, up, rec, record, warns, guess, can,
                    stature)


def _fold_static_root(work: Motion, clip: Clip | None, has_motion: bool,
                      given_up: np.ndarray | None, roles: dict, record: dict,
                      warns: list[str]) -> tuple[Motion, Clip | None]:
    """Step 1: the joints above the pelvis folded into it when they are a static chain (their
    first pose and the fold kept in ``record``, a note in ``warns``); ``(work, clip)``."""
    rec = recognise(work.skeleton, given_up, roles, clip)
    pelvis = rec.roles.get("pelvis")
    k = work.skeleton.index(pelvis) if isinstance(pelvis, str) else 0
    if k > 0 and static_chain_above(work.skeleton, k):
        fr = fold_record(work, k)
        fr["fold_pose"] = {work.skeleton.names[j]: {
            "position": [float(x) for x in work.local_positions[0, j]],
            "rotation": [float(x) for x in work.rotations[0, j]]} for j in range(k)}
        record.update(fr)
        work = fold_root(work, k)
        if fr["fold_rotation"] is not None:
            q = np.asarray(fr["fold_rotation"])
            work = rerest(work, np.tile(q, (work.skeleton.n_joints, 1)))
        clip = Clip.of(work) if has_motion else None
        warns.append(f"joints above the pelvis folded into the root {work.skeleton.names[0]!r}: "
                     + ", ".join(fr["fold"])
                     + (" (with their constant rotation)" if fr["fold_rotation"] else ""))
    return work, clip


def _up_and_roles(sk: Skeleton, up_axis: str | None, given_up: np.ndarray | None, roles: dict,
                  clip: Clip | None) -> tuple[str, Recognition]:
    """Step 3: the up axis (given, along the legs, or the rest pose's) and the roles found with
    it; without a role map, a skeleton that is not a standing biped is refused."""
    rec = recognise(sk, given_up, roles, clip)
    up = up_axis or _up_from_legs(sk, rec, clip) or guess_up_axis(sk)
    rec = recognise(sk, AXIS_VECTORS[up], roles, clip)
    if not roles:
        try:
            _check_biped(sk, AXIS_VECTORS[up], clip)
            _check_trunk(sk, rec, AXIS_VECTORS[up], clip)
        except ConversionError as e:
            if up_axis is None:
                raise
            raise ConversionError(f"{e} (with --up {up_axis}: if that is not the file's up "
                                  "axis, give another or leave it out)") from None
    return up, rec


def _check_essential_roles(rec: Recognition, names: list[str], roles: dict) -> None:
    """One :class:`ConversionError` listing the essential roles (pelvis, hips, knees, ankles)
    not found, with how to map them (no legs at all: "not a humanoid")."""
    missing = [r for r in ESSENTIAL_ROLES if r not in rec.roles]
    if missing:
        legs = [r for r in missing if r != "pelvis"]
        problem = rec.problem
        if problem is None and len(legs) == 6:
            problem = "no legs: no knee names and no two limb chains reaching the floor"
        elif problem is None and len(legs) == 3:
            problem = "one leg only"
        err = missing_roles_error(missing, names, rec.roles, problem)
        if len(legs) == 6 and rec.problem is None and not roles:
            err = ConversionError("not a humanoid: no legs (no knee names and no two limb "
                                  "chains of thigh and shank); if it is one, " + str(err))
        raise err


def _unit_scale(stature: float, unit: float | None,
                warns: list[str]) -> tuple[float, UnitGuess | None]:
    """Step 5: metres per file unit, given or guessed from the ``stature`` (file units), and the
    guess (``None`` when given); a note in ``warns`` when no known unit fits."""
    guess = None
    if unit is not None:
        scale = float(unit)
    else:
        guess = unit_from_stature(stature)
        scale = guess.scale
        if guess.name is None:
            warns.append(f"no known unit (m, dm, cm, mm, in, ft, cmu) makes this body 1.0-2.3 m "
                         f"tall: the anatomical scale {scale:.6g} m per unit is used (a "
                         f"{guess.height_m:.2f} m stature); pass --unit if you know the file's")
    return scale, guess


def _check_span(sk: Skeleton, scale: float) -> None:
    """Refuse a rest pose larger than :data:`MAX_SPAN_M` at ``scale`` (not a body)."""
    points = np.vstack([sk.rest_positions(), sk.rest_end_sites().reshape(-1, 3)])
    span = float((points.max(axis=0) - points.min(axis=0)).max()) * scale
    if span > MAX_SPAN_M:
        raise ConversionError(f"the skeleton spans {span:.3g} m at {scale:g} m per unit: not a "
                              f"body (at most {MAX_SPAN_M:g} m; check the OFFSETs or --unit)")


def describe_unit(prep: Prepared) -> str:
    """The unit in words: ``"cm (0.01 m per file unit, from the body's size)"``,
    ``"0.0564444 m per file unit (cmu, given)"``, ``"0.0531 m per file unit (the body's own
    scale: no known unit fits)"``."""
    g = prep.unit
    if g is None:
        name = unit_name(prep.scale)
        return f"{prep.scale:g} m per file unit ({name + ', ' if name else ''}given)"
    if g.name is None:
        return f"{g.scale:.6g} m per file unit (the body's own scale: no known unit fits)"
    return f"{g.name} ({g.scale:g} m per file unit, from the body's size)"


# ------------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------------
def _leg_joints(sk: Skeleton, rec: Recognition) -> list[tuple[int, int, int]] | None:
    out = []
    for s in ("left", "right"):
        names = [rec.roles.get(f"{s}_{r}") for r in ("hip", "knee", "ankle")]
        if not all(isinstance(n, str) for n in names):
            return None
        out.append(tuple(sk.index(n) for n in names))
    return out


def _check_biped(sk: Skeleton, up: np.ndarray, clip: Clip | None) -> None:
    """Refuse a skeleton with three or more limbs on the floor in the clip (and in its rest
    pose, unless that says nothing): :func:`mjchar.bvh.rigs.anatomy.floor_limbs`."""
    rest = anatomy.floor_limbs(sk, up)
    n = anatomy.floor_limbs(sk, up, clip.positions) if clip is not None else rest
    if n >= 3 and (clip is None or rest >= 3 or rest < 0):
        where = "over the clip" if clip is not None else "in the rest pose"
        raise ConversionError(f"not a humanoid: found {n} limbs reaching the floor {where} (a "
                              "two-legged humanoid stands on two); mjchar builds bipeds only")


def _check_trunk(sk: Skeleton, rec: Recognition, up: np.ndarray, clip: Clip | None) -> None:
    """Refuse legs whose trunk does not stand above them (a hand's fingers taken for legs:
    :func:`mjchar.bvh.rigs.anatomy.trunk_problem`, over the clip, or on a rest pose whose legs
    point down) or is not upright (a two-legged animal:
    :func:`mjchar.bvh.rigs.anatomy.upright_problem`)."""
    legs = []
    for s in ("left", "right"):
        hk = [rec.roles.get(f"{s}_{r}") for r in ("hip", "knee", "ankle")]
        if isinstance(hk[0], str) and isinstance(hk[1], str):
            hk[2] = hk[2] if isinstance(hk[2], str) else hk[1]
            legs.append(tuple(sk.index(n) for n in hk))
    pelvis = rec.roles.get("pelvis")
    tops = [sk.index(v) for r in ("head", "left_clavicle", "right_clavicle", "left_shoulder",
                                  "right_shoulder")
            if isinstance(v := rec.roles.get(r), str)]
    if not legs or not isinstance(pelvis, str):
        return
    P = clip.positions if clip is not None else sk.rest_positions()[None]
    if clip is None:
        down = np.mean([P[0, a] - P[0, h] for h, _, a in legs], axis=0)
        if float(down @ -up) < 0.7 * max(float(np.linalg.norm(down)), 1e-12):
            return  # a rest pose that is no standing figure says nothing
    problem = anatomy.trunk_problem(P, legs, sk.index(pelvis), tops) or anatomy.upright_problem(
        sk.rest_positions(), None if clip is None else clip.positions, legs, sk.index(pelvis),
        tops, up)
    if problem:
        raise ConversionError(f"not a humanoid: {problem}; mjchar builds bipeds only")


def _up_from_legs(sk: Skeleton, rec: Recognition, clip: Clip | None) -> str | None:
    """The file axis along the legs (hips minus ankles) over the clip, else the rest pose."""
    legs = _leg_joints(sk, rec)
    if legs is None:
        return None
    return structure.up_axis(sk, legs, clip) or structure.up_axis(sk, legs, None)


def _stature(sk: Skeleton, rec: Recognition, up: str) -> float:
    """File units: the rest's extent along ``up`` (joints and end sites), or the leg bones'
    estimate (hip to ankle = :data:`LEG_FRACTION` of the stature) when the two disagree by more
    than the rest pose can explain (a head without its top, a partial skeleton)."""
    pts = sk.rest_positions()
    if sk.n_end_sites:
        pts = np.concatenate([pts, sk.rest_end_sites()])
    i = axis_index(up)
    extent = float(pts[:, i].max() - pts[:, i].min())
    legs = _leg_joints(sk, rec)
    if legs is not None:
        rest = sk.rest_positions()
        leg = np.mean([np.linalg.norm(rest[k] - rest[h]) + np.linalg.norm(rest[a] - rest[k])
                       for h, k, a in legs])
        from_legs = leg / LEG_FRACTION
        if from_legs > 0 and not (0.75 < extent / from_legs < 1.35):
            extent = from_legs
    if extent <= 0:
        raise ConversionError("cannot guess the unit: the skeleton has no height; pass --unit")
    return extent


#: degrees: a forced change of the rest pose larger than this is said in a note
NOTE_DEG = 10.0


def _rest_notes(can: CanonicalRest) -> list[str]:
    """What the canonical rest changed, for the warnings (nothing for small changes)."""
    if can.from_bones:
        feet = "" if can.foot_pitch_deg is None else \
            f"; the feet pitched {can.foot_pitch_deg:.0f} deg as in the clip's flat stance"
        return ["the rest pose is not a standing figure (bones along local axes?): the "
                "canonical rest is built from the skeleton's bones, each joint's twist about "
                f"its bone from the clip's mean pose{feet}"]
    out = []
    if can.moved.get("pelvis", 0.0) > NOTE_DEG:
        out.append(f"the rest pose lies {can.moved['pelvis']:.0f} deg off the clip's up axis: "
                   "stood upright")
    moved = [f"{'legs straightened' if g == 'legs' else 'arms put in a T-pose'} (up to "
             f"{can.moved[g]:.0f} deg)" for g in ("legs", "arms")
             if can.moved.get(g, 0.0) > NOTE_DEG]
    if can.reaimed:
        what = ", ".join(can.reaimed[:8]) + (", ..." if len(can.reaimed) > 8 else "")
        moved.append(f"{what} re-aimed (not a human shape)")
    if can.foot_pitch_deg is not None:
        moved.append(f"feet pitched {can.foot_pitch_deg:.0f} deg")
    if moved:
        out.append("rest pose made canonical (standing, legs straight, arms in a T-pose): "
                   + ", ".join(moved))
    return out
