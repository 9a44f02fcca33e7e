"""The words of a joint name: namespace, side, and what body part it names.

Rigs in the wild spell the same joint ``lKnee``, ``LeftLeg``, ``mixamorig7:LeftLeg``,
``Armature|LeftLeg``, ``L_Knee``, ``knee.L``, ``Bip01 L Calf``, ``rknee`` (MakeHuman, all lower
case), ``lShin`` (Daz/Poser). :func:`tokens` reduces a name to lower-case words: the namespace
(``mixamorig7:``, ``Armature|``) dropped, camelCase, digits and separators split, and a side
letter glued to a body word (``rknee``, ``lshldr``, ``rcollar``) split off. The predicates below
say what a name names; :mod:`~mjchar.bvh.rigs.naming` turns them into roles.
"""

from __future__ import annotations

import re

#: finger words (a joint named with one is part of a hand)
FINGER_WORDS = ("finger", "thumb", "index", "middle", "ring", "pinky", "pinkie", "little",
                "metacarpal", "carpal", "phalanx")
#: words of a knee (the shank's joint): GAMES, CMU/Mixamo (``Leg``), Unreal (``calf``),
#: Daz/Poser (``Shin``), Xsens (``LowerLeg``), ASF (``tibia``)
KNEE_WORDS = ("knee", "shin", "calf", "crus", "lowerleg", "lowleg", "leg", "tibia")
#: words that are never a knee although they contain one of the above (the thigh's joint)
NOT_KNEE_WORDS = ("upleg", "upperleg", "thigh", "femur", "legupper")
#: words of an elbow (the forearm's joint): ``ForeArm``, ``lowerarm``, ASF ``radius``
ELBOW_WORDS = ("elbow", "forearm", "lowerarm", "lowarm", "radius", "ulna")
#: body words a side letter may be glued to (MakeHuman ``rknee``, ``lcollar``, ``rbuttock``)
_GLUED = ("hip", "knee", "ankle", "foot", "toe", "thigh", "shin", "calf", "leg", "upleg",
          "shoulder", "shldr", "elbow", "forearm", "arm", "uparm", "hand", "wrist", "collar",
          "clavicle", "buttock", "finger", "thumb", "index", "mid", "pinky", "eye", "ear",
          "femur", "tibia", "humerus", "radius", "ulna", "heel", "ball", "upper", "lower",
          "fore")
_SIDE_TOKENS = ("l", "r", "left", "right")


def strip_namespace(name: str) -> str:
    """``"mixamorig7:LeftLeg"`` -> ``"LeftLeg"``; ``"Armature|Hips"`` -> ``"Hips"``."""
    return re.split(r"[:|]", name)[-1]


def _unglue(tok: str) -> list[str]:
    if len(tok) > 3 and tok[0] in "lr" and tok[1:].startswith(_GLUED):
        return [tok[0], tok[1:]]
    return [tok]


def tokens(name: str) -> list[str]:
    """Lower-case words of a joint name: namespace dropped, camelCase, digits and separators
    split, a side letter glued to a body word split off.

    ``"mixamorig:LeftUpLeg"`` -> ``["left", "up", "leg"]``; ``"lTorso_Clavicle"`` ->
    ``["l", "torso", "clavicle"]``; ``"RHipJoint"`` -> ``["r", "hip", "joint"]``;
    ``"rknee"`` -> ``["r", "knee"]``; ``"finger2-2.r"`` -> ``["finger", "2", "2", "r"]``.
    """
    name = strip_namespace(name)
    name = re.sub(r"([a-z0-9])([A-Z])", r"\1 \2", name)  # lTorso -> l Torso
    name = re.sub(r"([A-Z])([A-Z][a-z])", r"\1 \2", name)  # LThumb -> L Thumb
    name = re.sub(r"([A-Za-z])(\d)", r"\1 \2", name)
    out: list[str] = []
    for t in re.split(r"[^A-Za-z0-9]+", name.lower()):
        if t:
            out += _unglue(t)
    return out


def side_of(name: str) -> str | None:
    """``"left"``/``"right"``/``None``: a standalone ``l``/``left`` (``r``/``right``) word."""
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


def core(name: str) -> str:
    """Name words without side words or digits, joined: ``"LeftUpLeg"`` -> ``"upleg"``."""
    return "".join(t for t in tokens(name) if t not in _SIDE_TOKENS and not t.isdigit())


def is_finger(name: str) -> bool:
    """True for finger/thumb joint names (``LeftHandIndex1``, ``LThumb``, ``lFinger2``,
    ``RightInHandMiddle``, ``finger2-2.r``, ``metacarpal3.l``)."""
    c = core(name)
    return any(w in c for w in FINGER_WORDS)


def is_end(name: str) -> bool:
    """True for end-marker joint names (``HeadTop_End``, ``LeftToe_End``, ``Bip01 L Toe0Nub``)."""
    toks = tokens(name)
    return bool(toks) and (toks[-1] in ("end", "nub", "site") or name.lower().endswith("nub"))


def is_twist(name: str) -> bool:
    """True for twist helpers inside a limb (``lForearmTwist``, ``upperarm_twist_01_l``,
    ``thigh_roll``): they turn about their bone and carry no anatomy of their own."""
    return bool({"twist", "roll"} & set(tokens(name)))


def is_knee(name: str) -> bool:
    c = core(name)
    if any(w in c for w in NOT_KNEE_WORDS) or {"up", "upper"} & set(tokens(name)):
        return False
    return any(w in c for w in KNEE_WORDS) and not is_end(name) and not is_twist(name)


def is_elbow(name: str) -> bool:
    c = core(name)
    return any(w in c for w in ELBOW_WORDS) and not is_end(name) and not is_twist(name)


def is_head(name: str) -> bool:
    return "head" in core(name) and not is_end(name) and side_of(name) is None
