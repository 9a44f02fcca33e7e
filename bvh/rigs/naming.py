"""Joint role recognition: which BVH joint is the left knee, the pelvis, a finger...

Rigs in the wild name the same joint differently (``lKnee``, ``LeftLeg``, ``mixamorig:LeftLeg``,
``L_Knee``, ``knee.L``), and some names are misleading: ``LeftShoulder`` is the clavicle in CMU and
Mixamo rigs but ``lShoulder`` is the upper-arm joint in the GAMES-105 rig; CMU's ``LHipJoint`` is a
zero-length helper while ``LeftUpLeg`` is the hip. Names alone therefore only find *anchors* (the
knees and elbows, whose names are unambiguous); the rest of each limb follows from the hierarchy:

- leg: ``hip`` = parent of the knee, ``ankle`` = the knee's child, ``toe`` = the ankle's child;
- arm: ``shoulder`` = parent of the elbow, ``clavicle`` = the shoulder's parent when it is on the
  same side, ``wrist`` = the elbow's child; everything below the wrist is the hand (fingers);
- trunk: ``pelvis`` = the joint where both legs branch off, ``head`` = the joint named head,
  ``neck`` = neck-named joints on the way to it, ``spine`` = the other joints between the pelvis
  and the head or clavicles.

A skeleton whose knees have no recognisable names still gets legs from its shape (the two limb
chains reaching nearest the floor, left and right from where the feet point), and one whose
elbows have none gets arms from its shape (the chains branching sideways from the upper spine);
those joints are reported in :attr:`Recognition.by_structure`. A user role map (``roles=``,
read from a TOML roles file by :mod:`mjchar.bvh.mjcf.roles`) anchors and overrides. Of the rest,
finger-named joints are ``"hand"``, end-marker leaves (``*_End``, ``*Nub``, ``*_Site``) ``"end"``,
everything else ``"unknown"``.

Sides: a name is left-sided when a token ``l``/``left`` starts or ends it (``lKnee``,
``LeftLeg``, ``Knee_L``, ``knee.l``), right-sided likewise with ``r``/``right``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from mjchar.bvh.io.skeleton import Skeleton

_FINGER_WORDS = ("finger", "thumb", "index", "middle", "ring", "pinky", "pinkie", "little")
_KNEE_WORDS = ("knee", "shin", "calf", "crus", "lowerleg", "lowleg", "leg")
_NOT_KNEE_WORDS = ("upleg", "upperleg", "thigh")
_ELBOW_WORDS = ("elbow", "forearm", "lowerarm", "lowarm")


@dataclass
class Recognition:
    """Roles found in a skeleton.

    Attributes:
        joint_roles: joint name -> role (``"left_knee"``, ``"spine"``, ``"hand"``, ``"unknown"``),
            for every joint.
        roles: role -> joint name for single roles (``"pelvis"``, ``"head"``, ``"left_hip"``...),
            role -> list of joint names for ``"spine"`` and ``"neck"`` (root to head order).
        by_structure: joints whose role came from the hierarchy's shape, not a name.
        unrecognised: joints with role ``"unknown"``.
        left_axis: unit vector ``(3,)`` in file axes pointing to the character's left, estimated
            from left/right joint pairs (``None`` when no pair exists).
        problem: why the legs could not be told apart (two leg chains found by shape whose sides
            the geometry cannot decide), or ``None``.
    """

    joint_roles: dict[str, str]
    roles: dict[str, object]
    by_structure: list[str] = field(default_factory=list)
    unrecognised: list[str] = field(default_factory=list)
    left_axis: np.ndarray | None = None
    problem: str | None = None

    def base_role(self, joint: str) -> str:
        """The role without its side: ``"left_knee"`` -> ``"knee"``."""
        role = self.joint_roles[joint]
        return role.split("_", 1)[1] if role.startswith(("left_", "right_")) else role

    def side(self, joint: str) -> str | None:
        """``"left"``, ``"right"`` or ``None``."""
        role = self.joint_roles[joint]
        return role.split("_", 1)[0] if role.startswith(("left_", "right_")) else None


def tokens(name: str) -> list[str]:
    """Lower-case words of a joint name: namespace dropped, camelCase and separators split.

    ``"mixamorig:LeftUpLeg"`` -> ``["left", "up", "leg"]``; ``"lTorso_Clavicle"`` ->
    ``["l", "torso", "clavicle"]``; ``"RHipJoint"`` -> ``["r", "hip", "joint"]``.
    """
    name = re.split(r"[:|]", name)[-1]
    name = re.sub(r"([a-z0-9])([A-Z])", r"\1 \2", name)  # lTorso -> l Torso
    name = re.sub(r"([A-Z])([A-Z][a-z])", r"\1 \2", name)  # LThumb -> L Thumb
    name = re.sub(r"([A-Za-z])(\d)", r"\1 \2", name)
    return [t for t in re.split(r"[^A-Za-z0-9]+", name.lower()) if t]


def side_of(name: str) -> str | None:
    """``"left"``/``"right"``/``None``: a standalone ``l``/``left`` (``r``/``right``) token."""
    toks = tokens(name)
    if not toks:
        return None
    left = "l" in toks or "left" in toks
    right = "r" in toks or "right" in toks
    if left and not right:
        return "left"
    if right and not left:
        return "right"
    return None


def _core(name: str) -> str:
    """Name tokens without side tokens or digits, joined: ``"LeftUpLeg"`` -> ``"upleg"``."""
    toks = tokens(name)
    toks = [t for t in toks if t not in ("l", "r", "left", "right") and not t.isdigit()]
    return "".join(toks)


def is_finger(name: str) -> bool:
    """True for finger/thumb joint names (``LeftHandIndex1``, ``LThumb``, ``lFinger2``)."""
    core = _core(name)
    return any(w in core for w in _FINGER_WORDS)


def is_end(name: str) -> bool:
    """True for end-marker joint names (``HeadTop_End``, ``LeftToe_End``, ``Bip01 L Toe0Nub``)."""
    toks = tokens(name)
    return bool(toks) and (toks[-1] in ("end", "nub", "site") or name.lower().endswith("nub"))


def _is_knee(name: str) -> bool:
    core = _core(name)
    if any(w in core for w in _NOT_KNEE_WORDS) or {"up", "upper"} & set(tokens(name)):
        return False
    return any(w in core for w in _KNEE_WORDS) and not is_end(name)


def _is_elbow(name: str) -> bool:
    core = _core(name)
    return any(w in core for w in _ELBOW_WORDS) and not is_end(name)


def recognise(skeleton: Skeleton, up: np.ndarray | None = None,
              roles: dict[str, object] | None = None) -> Recognition:
    """Assign a role to every joint of ``skeleton`` (names first, hierarchy shape as fallback).

    Args:
        skeleton: the skeleton (any units and axes).
        up: ``(3,)`` unit up vector in file axes, used by the shape fallback for legs and the
            head; guessed from the rest pose when ``None``.
        roles: a user mapping role -> joint name (``"spine"``/``"neck"``: a list of names), as
            read from a roles file (:mod:`bvh.role_map`); given knees and elbows anchor their
            limbs, and every given role overrides what recognition finds.

    Returns:
        A :class:`Recognition`. Never raises: missing roles are simply absent from ``roles``.
    """
    sk = skeleton
    n = sk.n_joints
    names = sk.names
    rest = sk.rest_positions()
    children = [sk.children(j) for j in range(n)]
    if up is None:
        from mjchar.bvh.rigs.units import AXIS_VECTORS, guess_up_axis
        up = AXIS_VECTORS[guess_up_axis(sk)] if n > 1 else np.array([0.0, 1.0, 0.0])
    up = np.asarray(up, dtype=float)
    height = _height(sk, up)

    role: dict[int, str] = {}
    by_structure: list[int] = []

    def descendants(j: int) -> list[int]:
        out, stack = [], list(children[j])
        while stack:
            c = stack.pop()
            out.append(c)
            stack.extend(children[c])
        return sorted(out)

    def main_child(j: int, prefer=None) -> int | None:
        """The child continuing a limb chain: prefer a named one, skip end/finger markers."""
        cands = [c for c in children[j] if not is_end(names[c]) and not is_finger(names[c])]
        if not cands:
            return None
        if prefer is not None:
            named = [c for c in cands if prefer(names[c])]
            if named:
                cands = named
        # the child whose subtree reaches farthest continues the chain
        return max(cands, key=lambda c: _reach(sk, rest, descendants, c))

    # -- legs: knees by name, then the chain around them ----------------------------------------
    user = {r: v for r, v in (roles or {}).items()}
    knees: dict[str, int] = {}
    for s in ("left", "right"):
        if isinstance(user.get(f"{s}_knee"), str) and user[f"{s}_knee"] in names:
            knees[s] = names.index(user[f"{s}_knee"])
    for j in range(n):
        if j and _is_knee(names[j]):
            s = side_of(names[j])
            if s and s not in knees:
                knees[s] = j
    problem = None
    if len(knees) < 2:
        shaped, problem = _legs_by_shape(sk, rest, up, height, children)
        knees = shaped or knees
        by_structure_legs = True
    else:
        by_structure_legs = False
    for s, k in knees.items():
        chain = {}
        chain["knee"] = k
        hip = int(sk.parents[k])
        if hip > 0:
            chain["hip"] = hip
        ankle = main_child(k, prefer=lambda nm: any(w in _core(nm) for w in ("ankle", "foot")))
        if ankle is not None:
            chain["ankle"] = ankle
            toe = main_child(ankle, prefer=lambda nm: any(w in _core(nm) for w in ("toe", "ball")))
            if toe is not None:
                chain["toe"] = toe
        for r, j in chain.items():
            if j not in role:
                role[j] = f"{s}_{r}"
                if by_structure_legs:
                    by_structure.append(j)

    # -- arms: elbows by name (or given), else by shape --------------------------------------------
    elbows: dict[int, str] = {}
    for s in ("left", "right"):
        if isinstance(user.get(f"{s}_elbow"), str) and user[f"{s}_elbow"] in names:
            elbows[names.index(user[f"{s}_elbow"])] = s
    for j in range(1, n):
        if j in role or j in elbows or not _is_elbow(names[j]):
            continue
        s = side_of(names[j])
        if s is None or s in elbows.values():
            continue
        elbows[j] = s
    arms_by_shape = False
    if not elbows and len(knees) == 2:
        elbows = _arms_by_shape(sk, rest, up, role, children, descendants)
        arms_by_shape = bool(elbows)
    for j, s in elbows.items():
        if j in role:
            continue
        role[j] = f"{s}_elbow"
        if arms_by_shape:
            by_structure.append(j)
        sh = int(sk.parents[j])
        if sh > 0 and sh not in role:
            role[sh] = f"{s}_shoulder"
            cl = int(sk.parents[sh])
            same_side = side_of(names[cl]) == s or (arms_by_shape and len(children[cl]) == 1)
            if cl > 0 and cl not in role and same_side:
                role[cl] = f"{s}_clavicle"
        wr = main_child(j, prefer=lambda nm: any(w in _core(nm) for w in ("wrist", "hand")))
        if wr is not None and wr not in role:
            role[wr] = f"{s}_wrist"
            for d in descendants(wr):
                role.setdefault(d, "hand")

    # -- trunk -------------------------------------------------------------------------------------
    hips = [h for h in (_find(role, "left_hip"), _find(role, "right_hip")) if h is not None]
    if len(hips) == 2:
        pelvis = _common_ancestor(sk, hips[0], hips[1])
    else:
        pelvis = 0
    role.setdefault(pelvis, "pelvis")
    head = None
    for j in range(1, n):
        if "head" in _core(names[j]) and not is_end(names[j]) and j not in role and \
                side_of(names[j]) is None:
            head = j
            break
    if head is None:  # shape fallback: the highest non-limb joint with no named role
        cands = [j for j in range(1, n) if j not in role and not is_end(names[j])
                 and side_of(names[j]) is None]
        if cands:
            top = max(cands, key=lambda j: float(rest[j] @ up))
            if rest[top] @ up > rest[pelvis] @ up + 0.25 * height:
                head = top
                by_structure.append(top)
    if head is not None:
        role[head] = "head"
    trunk_ends = [j for j in (head, _find(role, "left_clavicle"), _find(role, "right_clavicle"),
                              _find(role, "left_shoulder"), _find(role, "right_shoulder"))
                  if j is not None]
    for e in trunk_ends:
        for a in sk.chain(e)[:-1]:
            if a in role or a == pelvis or not _is_below(sk, pelvis, a):
                continue
            role[a] = "neck" if "neck" in _core(names[a]) else "spine"

    # -- leftovers: fingers, end markers, unknown -------------------------------------------------
    for j in range(n):
        if j in role:
            continue
        if is_finger(names[j]):
            role[j] = "hand"
        elif is_end(names[j]) and not children[j]:
            role[j] = "end"
        else:
            role[j] = "unknown"

    _apply_user_roles(role, user, names)
    joint_roles = {names[j]: role[j] for j in range(n)}
    roles: dict[str, object] = {}
    for j in range(n):
        r = role[j]
        if r in ("spine", "neck"):
            roles.setdefault(r, []).append(names[j])
        elif r not in ("hand", "end", "unknown"):
            roles[r] = names[j]
    return Recognition(
        joint_roles=joint_roles,
        roles=roles,
        by_structure=[names[j] for j in sorted(set(by_structure))],
        unrecognised=[names[j] for j in range(n) if role[j] == "unknown"],
        left_axis=_left_axis(rest, role, up),
        problem=problem,
    )


def _apply_user_roles(role: dict[int, str], user: dict, names: list[str]) -> None:
    """Given roles win: each given joint takes its role, which no other joint keeps."""
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


def _find(role: dict[int, str], r: str) -> int | None:
    for j, rr in role.items():
        if rr == r:
            return j
    return None


def _is_below(sk: Skeleton, ancestor: int, j: int) -> bool:
    return ancestor in sk.chain(j)


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


def _legs_by_shape(sk: Skeleton, rest: np.ndarray, up: np.ndarray, height: float,
                   children: list[list[int]]) -> tuple[dict[str, int], str | None]:
    """Knees of the two chains that reach nearest the floor, by shape alone.

    A leg ends at a leaf at most 25% of the standing height above the lowest point; the two
    legs are the lowest such leaf and the lowest one whose chain parts from it highest up (at
    the pelvis, not inside a foot). The knee is the chain joint nearest 28% of the height above
    the floor. Left and right come from the geometry: forward is where the feet point (leaf
    ahead of knee), left = up x forward; without a foot direction the file's +X is left (Y-up
    files facing +Z and Z-up files facing -Y both have their left at +X).

    Returns ``(knees, problem)``: ``{}`` when there are not two legs; ``problem`` says why two
    leg chains cannot be told apart (hips at the same lateral place), else ``None``.
    """
    if sk.n_joints < 4 or height <= 0:
        return {}, None
    pts = rest if not sk.n_end_sites else np.concatenate([rest, sk.rest_end_sites()])
    floor = float((pts @ up).min())
    leaves = [j for j in range(sk.n_joints) if not children[j]]
    low = sorted((j for j in leaves if float(rest[j] @ up) - floor < 0.25 * height),
                 key=lambda j: float(rest[j] @ up))
    if len(low) < 2:
        return {}, None
    a = low[0]
    ca = sk.chain(a)

    def split(b: int) -> int:  # length of the common part of the chains
        cb = sk.chain(b)
        k = 0
        while k < min(len(ca), len(cb)) and ca[k] == cb[k]:
            k += 1
        return k

    b = min(low[1:], key=lambda j: (split(j), float(rest[j] @ up)))
    k = split(b)
    legs = [ca[k:], sk.chain(b)[k:]]
    if any(len(c) < 3 for c in legs):
        return {}, None
    target = floor + 0.28 * height
    knees = [min(c[1:-1], key=lambda j: abs(float(rest[j] @ up) - target)) for c in legs]
    fwd = sum((rest[c[-1]] - rest[kn]) for c, kn in zip(legs, knees, strict=True))
    fwd = fwd - (fwd @ up) * up
    if np.linalg.norm(fwd) > 0.03 * height:
        left = np.cross(up, fwd / np.linalg.norm(fwd))
    else:
        left = np.array([1.0, 0.0, 0.0]) - up * up[0]
        left /= max(np.linalg.norm(left), 1e-12)
    sep = float((rest[legs[0][0]] - rest[legs[1][0]]) @ left)
    if abs(sep) < 0.02 * height:
        sep = float((rest[knees[0]] - rest[knees[1]]) @ left)
    if abs(sep) < 0.02 * height:
        return {}, (f"two leg chains ({sk.names[legs[0][0]]}, {sk.names[legs[1][0]]}) but their "
                    "hips and knees are not apart sideways, so left and right cannot be told "
                    "apart")
    return ({"left": knees[0], "right": knees[1]} if sep > 0
            else {"left": knees[1], "right": knees[0]}), None


def _arms_by_shape(sk: Skeleton, rest: np.ndarray, up: np.ndarray, role: dict[int, str],
                   children: list[list[int]], descendants) -> dict[int, str]:
    """Elbows of the two chains branching sideways from the upper spine, by shape alone.

    The spine is the path from the pelvis (where the legs part) to the highest joint outside
    the legs; an arm is a chain hanging from a spine joint, off that path, whose farthest point
    lies at least 15% of the height to one side (left from the hips). The elbow is the chain's
    second-to-last joint (last = wrist). Returns ``{elbow index: side}``."""
    hips = {r: j for j, r in role.items() if r in ("left_hip", "right_hip")}
    if len(hips) != 2:
        return {}
    lh, rh = hips["left_hip"], hips["right_hip"]
    left = rest[lh] - rest[rh]
    left = left - (left @ up) * up
    if np.linalg.norm(left) < 1e-9:
        return {}
    left /= np.linalg.norm(left)
    pelvis = _common_ancestor(sk, lh, rh)
    legs = set(descendants(lh)) | set(descendants(rh)) | {lh, rh}
    others = [j for j in descendants(pelvis) if j not in legs]
    if not others:
        return {}
    top = max(others, key=lambda j: float(rest[j] @ up))
    path = sk.chain(top)
    path = path[path.index(pelvis):]
    pts_all = rest if not sk.n_end_sites else np.concatenate([rest, sk.rest_end_sites()])
    height = float((pts_all @ up).max() - (pts_all @ up).min())
    best: dict[str, tuple[float, list[int]]] = {}
    for p in path[1:]:
        for c in children[p]:
            if c in path or c in legs:
                continue
            chain = [c]
            while children[chain[-1]]:
                chain.append(max(children[chain[-1]],
                                 key=lambda k: float(abs((rest[k] - rest[p]) @ left))))
            lat = float((rest[chain[-1]] - rest[p]) @ left)
            side = "left" if lat > 0 else "right"
            if abs(lat) > 0.15 * height and len(chain) >= 3 and \
                    abs(lat) > best.get(side, (0.0, []))[0]:
                best[side] = (abs(lat), chain)
    if len(best) != 2:
        return {}
    return {chain[-2]: side for side, (_, chain) in best.items()}


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
