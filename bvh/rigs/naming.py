"""Joint role recognition: which BVH joint is the left knee, the pelvis, a finger...

Rigs in the wild name the same joint differently (``lKnee``, ``LeftLeg``, ``mixamorig7:LeftLeg``,
``L_Knee``, ``knee.L``, ``rknee``, ``lShin``), and some names are misleading: ``LeftShoulder`` is
the clavicle in CMU and Mixamo rigs, ``RightShoulder`` the upper arm in Xsens MVN's own export
and ``lShoulder`` in the GAMES-105 rig; CMU's ``LHipJoint`` is a zero-length helper while
``LeftUpLeg`` is the hip. Names alone therefore only find *anchors* (the knees and elbows, whose
names are unambiguous; words in :mod:`~mjchar.bvh.rigs.words`); the rest of each limb follows
from the hierarchy:

- leg: ``hip`` = parent of the knee, ``ankle`` = the knee's child, ``toe`` = the ankle's child;
  the ankle's other children and the toe's are ``"toes"`` (phalanges, other toes);
- arm: ``shoulder`` = parent of the elbow, ``clavicle`` = the shoulder's parent when it is on the
  same side, ``wrist`` = the elbow's child; everything below the wrist is the hand (fingers);
  twist helpers (``lForearmTwist``) are walked over;
- trunk: ``pelvis`` = the joint where both legs and the trunk branch off, ``head`` = the joint
  named head, ``neck`` = neck-named joints on the way to it, ``spine`` = the other joints
  between the pelvis and the head or clavicles; everything below the head is ``"face"`` (jaw,
  eyes, tongue).

Where names fail, :mod:`~mjchar.bvh.rigs.structure` finds the legs, the arms and the head from the
skeleton's geometry and the clip's motion (mirror-image limb chains, the sides from where the
feet point); those joints are reported in :attr:`Recognition.by_structure`. Names win: the shape
only fills the limbs the names did not give, and never takes a joint a name gave another limb.
A user role map (``roles=``, read from a TOML roles file by :mod:`mjchar.bvh.mjcf.roles`) anchors
and overrides. Of the rest, finger-named joints are ``"hand"``, end-marker leaves (``*_End``,
``*Nub``, ``*_Site``) ``"end"``, twist helpers ``"twist"``, everything else ``"unknown"``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.rigs import structure
from mjchar.bvh.rigs.structure import Clip
from mjchar.bvh.rigs.words import (
    core,
    is_elbow,
    is_end,
    is_finger,
    is_head,
    is_knee,
    is_twist,
    side_of,
    tokens,
)

__all__ = ["Recognition", "recognise", "tokens", "side_of", "is_finger", "is_end", "is_twist",
           "Clip"]

#: roles of joints dropped by default (no body): fingers, end markers, the face, toe phalanges,
#: twist helpers without children
DETAIL_ROLES = ("hand", "end", "face", "toes")


@dataclass
class Recognition:
    """Roles found in a skeleton.

    Attributes:
        joint_roles: joint name -> role (``"left_knee"``, ``"spine"``, ``"hand"``, ``"unknown"``),
            for every joint.
        roles: role -> joint name for single roles (``"pelvis"``, ``"head"``, ``"left_hip"``...),
            role -> list of joint names for ``"spine"`` and ``"neck"`` (root to head order).
        by_structure: joints whose role came from the skeleton's geometry, not a name.
        unrecognised: joints with role ``"unknown"``.
        left_axis: unit vector ``(3,)`` in file axes pointing to the character's left, estimated
            from left/right joint pairs of the rest pose (``None`` when no pair exists).
        problem: why the legs could not be told apart (two leg chains found by shape whose sides
            the geometry cannot decide), or ``None``.
        given: joints whose role the user's role map gave.
    """

    joint_roles: dict[str, str]
    roles: dict[str, object]
    by_structure: list[str] = field(default_factory=list)
    unrecognised: list[str] = field(default_factory=list)
    left_axis: np.ndarray | None = None
    problem: str | None = None
    given: list[str] = field(default_factory=list)

    def base_role(self, joint: str) -> str:
        """The role without its side: ``"left_knee"`` -> ``"knee"``."""
        role = self.joint_roles[joint]
        return role.split("_", 1)[1] if role.startswith(("left_", "right_")) else role

    def side(self, joint: str) -> str | None:
        """``"left"``, ``"right"`` or ``None``."""
        role = self.joint_roles[joint]
        return role.split("_", 1)[0] if role.startswith(("left_", "right_")) else None

    def source(self, joint: str) -> str:
        """Where ``joint``'s role came from: ``"given"`` (the role map), ``"shape"`` (the
        skeleton's geometry and motion) or ``"name"`` (its name, or the hierarchy around a
        named knee or elbow)."""
        if joint in self.given:
            return "given"
        return "shape" if joint in self.by_structure else "name"


def recognise(skeleton: Skeleton, up: np.ndarray | None = None,
              roles: dict[str, object] | None = None, clip: Clip | None = None) -> Recognition:
    """Assign a role to every joint of ``skeleton`` (names first, geometry where they fail).

    Args:
        skeleton: the skeleton (any units and axes).
        up: ``(3,)`` unit up vector in file axes, used by the geometry (sides, the head);
            guessed from the rest pose when ``None``.
        roles: a user mapping role -> joint name (``"spine"``/``"neck"``: a list of names), as
            read from a roles file (:mod:`mjchar.bvh.mjcf.roles`); given knees and elbows anchor
            their limbs, and every given role overrides what recognition finds.
        clip: the motion's joint positions (:class:`~mjchar.bvh.rigs.structure.Clip`); the
            geometry reads the sides and end markers from it instead of the rest pose.

    Returns:
        A :class:`Recognition`. Never raises: missing roles are simply absent from ``roles``.
    """
    rr = _Recogniser(skeleton)
    user = {r: v for r, v in (roles or {}).items()}
    knees, elbows = rr.anchors(user)
    # legs: the named knees, else the geometry
    legs_pair = (structure.find_limbs(skeleton, rr.limb_joints(elbows))[0] if len(knees) < 2
                 else None)
    up = rr.up_vector(up, knees, legs_pair, clip)
    problem, left_geo, legs_by_shape = None, None, False
    if len(knees) < 2 and legs_pair is not None:
        shaped, left_geo, problem = structure.side_legs(
            skeleton, legs_pair, up, clip, lambda a: rr.main_child(a))
        if shaped:
            knees, legs_by_shape = shaped, True
    for s, k in knees.items():
        rr.leg_chain(s, k, legs_by_shape)
    # arms: the named elbows, else the geometry (never a joint a name gave a leg)
    arms_by_shape = rr.arms_by_shape(knees, elbows, left_geo, up, clip)
    for j, s in elbows.items():
        rr.arm_chain(j, s, j in arms_by_shape)
    # trunk, feet, leftovers
    rr.trunk(legs_by_shape, bool(arms_by_shape), up, clip)
    rr.feet()
    rr.leftovers()
    return rr.recognition(user, up, problem)


class _Recogniser:
    """The state of :func:`recognise`: the skeleton's hierarchy and rest pose, the roles found
    so far (joint -> role, in the order found) and the joints the shape gave."""

    def __init__(self, sk: Skeleton) -> None:
        self.sk = sk
        self.n = sk.n_joints
        self.names = sk.names
        self.rest = sk.rest_positions()
        self.children = [sk.children(j) for j in range(self.n)]
        self.role: dict[int, str] = {}
        self.by_structure: list[int] = []

    def descendants(self, j: int) -> list[int]:
        """The joints below ``j``, sorted."""
        out, stack = [], list(self.children[j])
        while stack:
            c = stack.pop()
            out.append(c)
            stack.extend(self.children[c])
        return sorted(out)

    def main_child(self, j: int, prefer=None) -> int | None:
        """The child continuing a limb chain: prefer a named one, skip end/finger markers,
        walk over twist helpers."""
        names = self.names
        cands = [c for c in self.children[j] if not is_end(names[c]) and not is_finger(names[c])]
        if not cands:
            return None
        if prefer is not None:
            named = [c for c in cands if prefer(names[c])]
            if named:
                cands = named
        # the child whose subtree reaches farthest continues the chain
        c = max(cands, key=lambda c: _reach(self.sk, self.rest, self.descendants, c))
        if is_twist(names[c]) and self.children[c]:
            self.role.setdefault(c, "twist")
            return self.main_child(c, prefer) or c
        return c

    def upper(self, j: int) -> int:
        """The joint above ``j``, walking over twist helpers."""
        p = int(self.sk.parents[j])
        while p > 0 and is_twist(self.names[p]):
            self.role.setdefault(p, "twist")
            p = int(self.sk.parents[p])
        return p

    def limb_joints(self, anchors) -> set[int]:
        """The ``anchors`` (knees or elbows), their parents and everything below them."""
        out = set()
        for a in anchors:
            out |= {a, int(self.sk.parents[a])}
            out |= set(self.descendants(a))
        return out

    def anchors(self, user: dict) -> tuple[dict[str, int], dict[int, str]]:
        """``(knees side -> joint, elbows joint -> side)`` given in the role map or named."""
        names = self.names
        knees: dict[str, int] = {}
        elbows: dict[int, str] = {}
        for s in ("left", "right"):
            if isinstance(user.get(f"{s}_knee"), str) and user[f"{s}_knee"] in names:
                knees[s] = names.index(user[f"{s}_knee"])
            if isinstance(user.get(f"{s}_elbow"), str) and user[f"{s}_elbow"] in names:
                elbows[names.index(user[f"{s}_elbow"])] = s
        for j in range(1, self.n):
            s = side_of(names[j])
            if s is None:
                continue
            if is_knee(names[j]) and s not in knees:
                knees[s] = j
            elif is_elbow(names[j]) and j not in elbows and s not in elbows.values() \
                    and j not in knees.values():
                elbows[j] = s
        return knees, elbows

    def up_vector(self, up: np.ndarray | None, knees: dict[str, int], legs_pair,
                  clip: Clip | None) -> np.ndarray:
        """``up`` as given, else along the legs (over the clip), else the rest pose's tallest
        extent."""
        sk = self.sk
        if up is None:
            from mjchar.bvh.rigs.units import AXIS_VECTORS, guess_up_axis
            if len(knees) == 2:
                legs3 = [(self.upper(k), k, self.main_child(k) or k) for k in knees.values()]
            else:
                legs3 = structure.pair_legs(legs_pair) if legs_pair is not None else []
            ax = structure.up_axis(sk, legs3, clip) if legs3 else None
            up = AXIS_VECTORS[ax or guess_up_axis(sk)] if self.n > 1 else np.array([0.0, 1.0, 0.0])
        return np.asarray(up, dtype=float)

    def leg_chain(self, s: str, k: int, by_shape: bool) -> None:
        """The roles of the leg around knee ``k`` on side ``s``: hip, knee, ankle, toe."""
        role = self.role
        chain = {"knee": k}
        hip = self.upper(k)
        if hip > 0:
            chain["hip"] = hip
        ankle = self.main_child(k, prefer=lambda nm: any(w in _core(nm)
                                                         for w in ("ankle", "foot")))
        if ankle is not None:
            chain["ankle"] = ankle
            toe = self.main_child(ankle, prefer=lambda nm: any(w in _core(nm)
                                                               for w in ("toe", "ball")))
            if toe is not None:
                chain["toe"] = toe
        for r, j in chain.items():
            if j not in role or role[j] == "twist":
                role[j] = f"{s}_{r}"
                if by_shape:
                    self.by_structure.append(j)

    def arms_by_shape(self, knees: dict[str, int], elbows: dict[int, str],
                      left_geo: np.ndarray | None, up: np.ndarray, clip: Clip | None) -> set[int]:
        """Elbows the geometry finds when fewer than two are named (added to ``elbows``): the
        first mirror pair of chains that holds no leg joint, sided by the character's left."""
        arms: set[int] = set()
        if len(elbows) < 2 and len(knees) == 2:
            sk = self.sk
            leg_joints = set(self.role) | self.limb_joints(knees.values())
            cands = [p for p in structure.mirror_pairs(sk)
                     if not (set(p.paths[0]) | set(p.paths[1])) & leg_joints]
            arms_pair = cands[0] if cands else None
            if arms_pair is not None:
                left = left_geo if left_geo is not None else _leg_lefts(sk, self.role, up, clip)
                if left is not None:
                    for j, s in structure.side_arms(sk, arms_pair, left, clip).items():
                        if j not in elbows and s not in elbows.values():
                            elbows[j] = s
                            arms.add(j)
        return arms

    def arm_chain(self, j: int, s: str, by_shape: bool) -> None:
        """The roles of the arm around elbow ``j`` on side ``s``: shoulder, clavicle (on the
        same side), elbow, wrist, and the hand below it."""
        role, sk = self.role, self.sk
        if j in role:
            return
        role[j] = f"{s}_elbow"
        if by_shape:
            self.by_structure.append(j)
        sh = self.upper(j)
        if sh > 0 and sh not in role:
            role[sh] = f"{s}_shoulder"
            if by_shape:
                self.by_structure.append(sh)
            cl = int(sk.parents[sh])
            same_side = side_of(self.names[cl]) == s or (by_shape and len(self.children[cl]) == 1)
            if cl > 0 and cl not in role and same_side:
                role[cl] = f"{s}_clavicle"
                if by_shape:
                    self.by_structure.append(cl)
        wr = self.main_child(j, prefer=lambda nm: any(w in _core(nm) for w in ("wrist", "hand")))
        if wr is not None and wr not in role:
            role[wr] = f"{s}_wrist"
            if by_shape:
                self.by_structure.append(wr)
            for d in self.descendants(wr):
                role.setdefault(d, "hand")

    def trunk(self, legs_by_shape: bool, arms_by_shape: bool, up: np.ndarray,
              clip: Clip | None) -> None:
        """Pelvis, head (named, else from the shape), the face below it, and the neck and
        spine joints between the pelvis and the head or the arms."""
        role, sk, names = self.role, self.sk, self.names
        hips = [h for h in (_find(role, "left_hip"), _find(role, "right_hip")) if h is not None]
        pelvis = _common_ancestor(sk, hips[0], hips[1]) if len(hips) == 2 else 0
        head, neck_path = self.head(pelvis, len(hips) == 2 and (legs_by_shape or arms_by_shape),
                                    up, clip)
        if head is not None:
            role[head] = "head"
            if pelvis not in sk.chain(head):  # a hip/pelvis split (Daz: hip -> pelvis, abdomen)
                pelvis = _common_ancestor(sk, pelvis, head)
            for d in self.descendants(head):
                role.setdefault(d, "end" if is_end(names[d]) and not self.children[d] else "face")
        for j in neck_path:
            role.setdefault(j, "neck")
            self.by_structure.append(j)
        role.setdefault(pelvis, "pelvis")
        trunk_ends = [j for j in (head, _find(role, "left_clavicle"),
                                  _find(role, "right_clavicle"), _find(role, "left_shoulder"),
                                  _find(role, "right_shoulder"))
                      if j is not None]
        if legs_by_shape:
            self.by_structure.append(pelvis)
        for e in trunk_ends:
            path = sk.chain(e)  # one walk up per end (a joint is below the pelvis iff it comes
            below = path.index(pelvis) + 1 if pelvis in path else len(path)  # after it on the path)
            for a in path[below:-1]:
                if a in role:
                    continue
                role[a] = "neck" if "neck" in _core(names[a]) else "spine"
                if e in self.by_structure:  # found around a joint the shape gave
                    self.by_structure.append(a)

    def head(self, pelvis: int, by_shape: bool, up: np.ndarray,
             clip: Clip | None) -> tuple[int | None, list[int]]:
        """``(head, neck path)``: the head-named joint, else (``by_shape``: limbs the shape
        gave) the geometry's, else the highest joint of no role well above the pelvis."""
        role, names, rest = self.role, self.names, self.rest
        head = None
        for j in range(1, self.n):
            if j not in role and is_head(names[j]):
                head = j
                break
        neck_path: list[int] = []
        if head is None and by_shape:
            head, neck_path = _head_by_structure(self.sk, role, pelvis, self.children,
                                                 self.descendants, clip)
            if head is not None:
                self.by_structure.append(head)
        if head is None:  # shape fallback: the highest non-limb joint with no named role
            cands = [j for j in range(1, self.n) if j not in role and not is_end(names[j])
                     and side_of(names[j]) is None]
            if cands:
                top = max(cands, key=lambda j: float(rest[j] @ up))
                if rest[top] @ up > rest[pelvis] @ up + 0.25 * _height(self.sk, up):
                    head = top
                    self.by_structure.append(top)
        return head, neck_path

    def feet(self) -> None:
        """Below each ankle: toe phalanges and other toes (``"toes"``), end markers."""
        role, names = self.role, self.names
        for s in ("left", "right"):
            a, t = _find(role, f"{s}_ankle"), _find(role, f"{s}_toe")
            if a is None:
                continue
            for d in self.descendants(a):
                if d != t and d not in role:
                    role[d] = "end" if is_end(names[d]) and not self.children[d] else "toes"

    def leftovers(self) -> None:
        """The joints still without a role: fingers, end markers, twist helpers, unknown."""
        role, names = self.role, self.names
        for j in range(self.n):
            if j in role:
                continue
            if is_finger(names[j]):
                role[j] = "hand"
            elif is_end(names[j]) and not self.children[j]:
                role[j] = "end"
            elif is_twist(names[j]):
                role[j] = "twist"
            else:
                role[j] = "unknown"

    def recognition(self, user: dict, up: np.ndarray, problem: str | None) -> Recognition:
        """The :class:`Recognition`, the user's roles applied over what was found."""
        role, names, n = self.role, self.names, self.n
        given = _apply_user_roles(role, user, names)
        joint_roles = {names[j]: role[j] for j in range(n)}
        out_roles: dict[str, object] = {}
        for j in range(n):
            r = role[j]
            if r in ("spine", "neck"):
                out_roles.setdefault(r, []).append(names[j])
            elif r not in ("hand", "end", "unknown", "face", "toes", "twist"):
                out_roles[r] = names[j]
        shape = {j for j in self.by_structure
                 if role[j] not in ("unknown", "hand", "end", "twist")}
        return Recognition(
            joint_roles=joint_roles,
            roles=out_roles,
            by_structure=[names[j] for j in sorted(shape) if j not in given],
            unrecognised=[names[j] for j in range(n) if role[j] == "unknown"],
            left_axis=_left_axis(self.rest, role, up),
            problem=problem,
            given=[names[j] for j in sorted(given)],
        )


def _core(name: str) -> str:
    return core(name)


def _leg_lefts(sk: Skeleton, role: dict[int, str], up: np.ndarray,
               clip: Clip | None) -> np.ndarray | None:
    """The character's left per frame from its recognised hips (``None`` without both)."""
    lh, rh = _find(role, "left_hip"), _find(role, "right_hip")
    if lh is None or rh is None:
        return None
    return structure.hips_left(sk, lh, rh, clip)


def _head_by_structure(sk, role, pelvis, children, descendants, clip):
    """``(head, neck joints)`` from the geometry: up the chain from the arms' branch point (or
    the pelvis when there are no arms) that reaches farthest."""
    arm_roots = [j for j in (_find(role, f"{s}_{r}") for s in ("left", "right")
                             for r in ("clavicle", "shoulder")) if j is not None]
    avoid = set()
    for j, r in role.items():
        if r.startswith(("left_", "right_")):
            avoid.add(j)
    top = pelvis
    if arm_roots:
        top = int(sk.parents[arm_roots[0]])
        for a in arm_roots[1:]:
            top = _common_ancestor(sk, top, int(sk.parents[a]))
        if top == pelvis or pelvis not in sk.chain(top):
            top = pelvis
    path = structure.head_by_structure(sk, top, avoid, clip)
    if not path:
        return None, []
    return path[-1], path[:-1] if top != pelvis else []
def _apply_user_roles(role: dict[int, str], user: dict, names: list[str]) -> set[int]:
    """Given roles win: each given joint takes its role, which no other joint keeps. Returns
    the given joints."""
    out: set[int] = set()
    for r, v in user.items():
        given = [v] if isinstance(v, str) else list(v)
        idx = [names.index(x) for x in given if x in names]
        if not idx:
            continue
        base = r if r in ("spine", "neck") else None
        for j, rr in list(role.items()):
            if rr == r and base is None and j not in idx:
                role[j] = "unknown"
        for j in idx:
            role[j] = r
            out.add(j)
    return out


def _find(role: dict[int, str], r: str) -> int | None:
    for j, rr in role.items():
        if rr == r:
            return j
    return None


def _common_ancestor(sk: Skeleton, a: int, b: int) -> int:
    ca, cb = sk.chain(a), sk.chain(b)
    common = 0
    for x, y in zip(ca, cb, strict=False):
        if x != y:
            break
        common = x
    return common


def _height(sk: Skeleton, up: np.ndarray) -> float:
    pts = sk.rest_positions()
    if sk.n_end_sites:
        pts = np.concatenate([pts, sk.rest_end_sites()])
    h = pts @ up
    return float(h.max() - h.min()) if len(h) else 0.0


def _reach(sk: Skeleton, rest: np.ndarray, descendants, j: int) -> float:
    """Farthest distance from joint ``j`` to any of its descendants or end sites."""
    pts = [rest[d] for d in descendants(j)]
    ends = sk.rest_end_sites()
    pts += [ends[e] for e in range(sk.n_end_sites) if sk.end_site_parents[e] == j
            or sk.end_site_parents[e] in descendants(j)]
    if not pts:
        return 0.0
    return float(np.max(np.linalg.norm(np.asarray(pts) - rest[j], axis=1)))


def _left_axis(rest: np.ndarray, role: dict[int, str], up: np.ndarray) -> np.ndarray | None:
    """Mean direction from right to left joints of the same role, made horizontal."""
    diffs = []
    for j, r in role.items():
        if r.startswith("left_"):
            other = _find(role, "right_" + r[5:])
            if other is not None:
                diffs.append(rest[j] - rest[other])
    if not diffs:
        return None
    v = np.sum(diffs, axis=0)
    v = v - (v @ up) * up
    norm = np.linalg.norm(v)
    return v / norm if norm > 1e-9 else None
