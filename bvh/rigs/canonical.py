"""A canonical rest for every skeleton: standing, legs straight down, arms in a T-pose.

The simulated body's rest pose is built from the skeleton and its roles, not from a frame of
whichever clip came with it, so the same skeleton gives the same body from every clip. Each
joint gets a rest orientation ``R_j`` (a rotation of the file's zero pose, applied with
:func:`mjchar.bvh.rigs.layouts.rerest`, which moves no joint of any frame):

- **forced** (the canonical pose): the thigh and shank bones (hip, knee) point straight down;
  the upper arm and forearm bones (shoulder, elbow) point straight out to the side, a T-pose;
- **kept when plausible** (the file's own shape where it is a human one): the pelvis (the hips
  side by side along the left axis, the spine above), each spine and neck joint (its bone within
  :data:`TRUNK_DEG` of up, the clavicles it carries side by side), the head (within
  :data:`HEAD_DEG` of up), clavicles and hands (within :data:`ARM_DEG` of the arm's side),
  feet (pointing forward, pitched :data:`FOOT_PITCH_DEG` at most) and toes (forward, within
  :data:`TOE_PITCH_DEG` of level) keep the file's orientation relative to their parent (feet and
  toes: to the pelvis, so a straightened leg does not roll them). Where the file's is not
  plausible (bones along local axes, as game engines export), the segment is turned the least
  way onto its canonical direction: up for the trunk and head (the clavicles side by side),
  sideways for clavicles and hands, forward for toes, and forward pitched down for feet by the
  pitch the clip's flat stance shows (the only thing read from the clip, since the skeleton
  cannot tell it) or :data:`DEFAULT_FOOT_PITCH_DEG` without a clip;
- **rigid** with their parent: everything else (helpers, fingers, face, unknown joints).

The frame: up is the file's up axis; the character's left the file axis (across up) nearest the
left hip's side of the pelvis in the zero pose; forward = left x up. A skeleton whose zero pose
already is this rest (the bundled humanoid, the GAMES-105 rig: every rule gives the identity)
is left exactly as it is.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.rigs.naming import Recognition
from mjchar.bvh.rigs.structure import Clip
from mjchar.bvh.rigs.units import AXIS_VECTORS

#: degrees: a trunk bone (pelvis to spine, spine to spine or neck) kept when this close to up
TRUNK_DEG = 30.0
#: degrees: the hips (or the clavicles) kept when their left-right line is this close to level
PAIR_DEG = 20.0
#: degrees: a head bone kept when this close to up
HEAD_DEG = 45.0
#: degrees: clavicle and hand bones kept when this close to their side
ARM_DEG = 50.0
#: degrees: a foot kept when its heading is this close to forward and its pitch in range
FOOT_HEADING_DEG = 50.0
FOOT_PITCH_DEG = (-20.0, 70.0)
#: degrees: toes kept when pitched at most this much from level
TOE_PITCH_DEG = 45.0
#: degrees: the foot's pitch (ankle to toe joint, below level) when neither the file nor a clip
#: tells it
DEFAULT_FOOT_PITCH_DEG = 25.0

@dataclass
class CanonicalRest:
    """The canonical rest of a skeleton.

    Attributes:
        rest: ``(J, 4)`` wxyz rest orientation per joint (world frame of the file's zero pose),
            or ``None`` when the zero pose already is the canonical rest.
        left: ``(3,)`` the file axis the character's left lies along.
        moved: degrees each group of forced segments turned (``"legs"``, ``"arms"``; the
            largest of the group), for the converter's notes.
        reaimed: joints whose file orientation was not plausible and was replaced.
        foot_pitch_deg: the feet's pitch when it was not the file's (from the clip or the
            default), else ``None``.
        from_bones: True when the zero pose was no human pose and the rest was built from the
            bones (twists from the clip's mean pose).
    """

    rest: np.ndarray | None
    left: np.ndarray
    moved: dict[str, float] = field(default_factory=dict)
    reaimed: list[str] = field(default_factory=list)
    foot_pitch_deg: float | None = None
    from_bones: bool = False


def _unit(v: np.ndarray) -> np.ndarray | None:
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-12 else None


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip(a @ b, -1.0, 1.0))))


def swing(a: np.ndarray, b: np.ndarray, spare: np.ndarray) -> np.ndarray:
    """``(3, 3)``: the least rotation taking unit ``a`` to unit ``b`` (exactly the identity when
    they agree; half a turn about ``spare``, made normal to ``a``, when they are opposite)."""
    c = float(a @ b)
    axis = np.cross(a, b)
    s = float(np.linalg.norm(axis))
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        axis = spare - (spare @ a) * a
        if np.linalg.norm(axis) < 1e-9:
            axis = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
        return Rotation.from_rotvec(np.pi * axis / np.linalg.norm(axis)).as_matrix()
    return Rotation.from_rotvec(axis / s * np.arctan2(s, c)).as_matrix()


def _frame(x: np.ndarray, y: np.ndarray) -> np.ndarray | None:
    y = y - (y @ x) * x
    y = _unit(y)
    if y is None:
        return None
    return np.stack([x, y, np.cross(x, y)], axis=1)


def align(a1, b1, a2, b2, spare) -> np.ndarray:
    """``(3, 3)``: the rotation taking unit ``a1`` to ``b1`` and ``a2`` as near ``b2`` as it can
    (the least rotation ``a1 -> b1`` when ``a2`` is along ``a1``)."""
    ma, mb = _frame(a1, a2), _frame(b1, b2)
    if ma is None or mb is None:
        return swing(a1, b1, spare)
    return mb @ ma.T


def canonical_rest(sk: Skeleton, rec: Recognition, up: str,
                   clip: Clip | None = None) -> CanonicalRest:
    """The canonical rest of ``sk`` with roles ``rec`` and the file's ``up`` axis (module
    docstring). ``clip`` is read only where the skeleton cannot tell: the feet's pitch when the
    file's is not plausible, and, for a zero pose that is no human pose, each joint's twist
    about its bone."""
    g = _Geometry(sk, rec, up)
    R_pel = g.pelvis_rotation()
    if g.human_pose(R_pel):
        return g.from_file(R_pel, clip)
    return g.from_bones(R_pel, clip)


class _Geometry:
    """The skeleton's zero pose, its roles and the canonical frame (up, left, forward)."""

    def __init__(self, sk: Skeleton, rec: Recognition, up: str):
        self.sk, self.rec = sk, rec
        self.n = sk.n_joints
        self.P = sk.rest_positions()
        self.ends = sk.rest_end_sites() if sk.n_end_sites else np.zeros((0, 3))
        self.size = float(np.ptp(np.concatenate([self.P, self.ends]), axis=0).max()) or 1.0
        self.far = 1e-6 * self.size
        self.U = U = AXIS_VECTORS[up]
        lh, rh = self.idx("left_hip"), self.idx("right_hip")
        self.pair = (self.P[lh] - self.P[rh]) if lh is not None and rh is not None \
            else np.zeros(3)
        cands = [s * AXIS_VECTORS[a] for a in "xyz" if a != up[-1] for s in (1.0, -1.0)]
        pair_h = self.pair - (self.pair @ U) * U
        self.L = max(cands, key=lambda c: float(c @ pair_h)) \
            if np.linalg.norm(pair_h) > 1e-9 * self.size else cands[0]
        self.F = np.cross(self.L, U)
        self.pelvis = self.idx("pelvis")
        self.head = self.idx("head")
        self.spine_like = {sk.index(x) for r in ("spine", "neck") for x in rec.roles.get(r, [])}
        self.top = self.head
        for r in ("left_clavicle", "left_shoulder", "right_clavicle", "right_shoulder"):
            if self.top is None:
                self.top = self.idx(r)

    def idx(self, role: str) -> int | None:
        v = self.rec.roles.get(role)
        return self.sk.index(v) if isinstance(v, str) else None

    # -- directions in the zero pose ------------------------------------------------------------
    def toward(self, j: int, target: int | None) -> np.ndarray | None:
        """Unit vector from ``j`` to the first joint on the way to ``target`` not at ``j``."""
        if target is None or target == j or j not in self.sk.chain(target):
            return None
        ch = self.sk.chain(target)
        for k in ch[ch.index(j) + 1:]:
            if np.linalg.norm(self.P[k] - self.P[j]) > self.far:
                return _unit(self.P[k] - self.P[j])
        return None

    def own_points(self, j: int) -> np.ndarray:
        sk = self.sk
        out = [self.P[c] for c in sk.children(j)]
        out += [self.ends[e] for e in range(sk.n_end_sites) if sk.end_site_parents[e] == j]
        return np.asarray(out).reshape(-1, 3)

    def farthest(self, j: int) -> np.ndarray | None:
        """Unit vector to the farthest point of ``j``'s subtree (end sites included)."""
        sk = self.sk
        inside = sk.in_subtree(j)
        pts = [self.P[k] for k in np.flatnonzero(inside) if k != j]
        pts += [self.ends[e] for e in np.flatnonzero(inside[sk.end_site_parents])]
        if not pts:
            return None
        pts = np.asarray(pts)
        return _unit(pts[np.argmax(np.linalg.norm(pts - self.P[j], axis=1))] - self.P[j])

    def lr_pair(self, j: int) -> np.ndarray | None:
        """Right-to-left vector of the arms hanging below trunk joint ``j`` (clavicles, else
        shoulders), when both hang below it."""
        for r in ("clavicle", "shoulder"):
            a, b = self.idx(f"left_{r}"), self.idx(f"right_{r}")
            if a is None or b is None or j not in self.sk.chain(a) or j not in self.sk.chain(b):
                continue
            if np.linalg.norm(self.P[a] - self.P[b]) > self.far:
                return self.P[a] - self.P[b]
        return None

    def bone(self, j: int) -> tuple[np.ndarray | None, np.ndarray | None]:
        """``(direction, canonical direction)`` of joint ``j``'s bone in the zero pose (either
        ``None`` when the role has none); the feet's canonical pitch is applied by the caller
        (``-U`` marks it here)."""
        nm = self.sk.names[j]
        base, side = self.rec.base_role(nm), self.rec.side(nm)
        s = 1.0 if side == "left" else -1.0
        U, L, F = self.U, self.L, self.F
        if j in self.spine_like:
            return self.toward(j, self.top), U
        if base == "head":
            own = [self.ends[e] for e in range(self.sk.n_end_sites)
                   if self.sk.end_site_parents[e] == j]
            return (_unit(np.mean(own, axis=0) - self.P[j]) if own else None), U
        if not side:
            return None, None
        if base in ("hip", "knee", "shoulder", "elbow", "clavicle"):
            nxt = {"hip": "knee", "knee": "ankle", "shoulder": "elbow", "elbow": "wrist",
                   "clavicle": "shoulder"}[base]
            v = self.toward(j, self.idx(f"{side}_{nxt}"))
            if v is None and base == "elbow":
                pts = self.own_points(j)
                v = _unit(pts.mean(axis=0) - self.P[j]) if len(pts) else None
            return v, (-U if base in ("hip", "knee") else s * L)
        if base == "wrist":
            pts = self.own_points(j)
            return (_unit(pts.mean(axis=0) - self.P[j]) if len(pts) else None), s * L
        if base == "ankle":
            t = self.idx(f"{side}_toe")
            v = self.toward(j, t) if t is not None else None
            return (v if v is not None else self.farthest(j)), None
        if base == "toe":
            return self.farthest(j), F
        return None, None

    # -- the pelvis, and whether the zero pose is a human one -----------------------------------
    def pair_ok(self, vec: np.ndarray | None) -> bool:
        """A right-to-left line that is level and along the left axis (or none)."""
        w = _unit(vec) if vec is not None else None
        if w is None:
            return True
        h = _unit(w - (w @ self.U) * self.U)
        return h is not None and abs(90.0 - _angle(w, self.U)) <= PAIR_DEG \
            and _angle(h, self.L) <= PAIR_DEG

    def pelvis_rotation(self) -> np.ndarray:
        """The pelvis: kept when its hips are level along the left axis and the trunk rises
        above it, else turned so (the trunk up, the hips along left)."""
        if self.pelvis is None:
            return np.eye(3)
        v = self.toward(self.pelvis, self.top)
        if self.pair_ok(self.pair) and (v is None or _angle(v, self.U) <= TRUNK_DEG):
            return np.eye(3)
        w = _unit(self.pair)
        if v is not None and w is not None:
            return align(v, self.U, w, self.L, self.F)
        if w is not None:
            return swing(w, self.L, self.U)
        return swing(v, self.U, self.F) if v is not None else np.eye(3)

    def human_pose(self, R_pel: np.ndarray) -> bool:
        """The zero pose, seen from the (turned) pelvis, is a human one: thighs and shanks
        within :data:`LEG_DEG` of down, the trunk within it of up."""
        for s in ("left", "right"):
            for a, b in (("hip", "knee"), ("knee", "ankle")):
                ja, jb = self.idx(f"{s}_{a}"), self.idx(f"{s}_{b}")
                v = self.toward(ja, jb) if ja is not None else None
                if v is not None and _angle(R_pel @ v, -self.U) > LEG_DEG:
                    return False
        v = self.toward(self.pelvis, self.top) if self.pelvis is not None else None
        return v is None or _angle(R_pel @ v, self.U) <= LEG_DEG

    # -- the two ways of building the rest ------------------------------------------------------
    def _result(self, R: list[np.ndarray], moved, reaimed, foot_pitch) -> CanonicalRest:
        if all(np.allclose(r, np.eye(3), atol=1e-12, rtol=0) for r in R):
            return CanonicalRest(None, self.L, moved, reaimed, foot_pitch)
        q = Rotation.from_matrix(np.asarray(R)).as_quat(scalar_first=True)
        q[q[:, 0] < 0] *= -1.0
        for j, r in enumerate(R):  # exact identities stay exact
            if np.allclose(r, np.eye(3), atol=1e-12, rtol=0):
                q[j] = [1.0, 0.0, 0.0, 0.0]
        return CanonicalRest(q, self.L, moved, reaimed, foot_pitch)

    def from_file(self, R_pel: np.ndarray, clip: Clip | None) -> CanonicalRest:
        """A human zero pose: legs straightened and arms put in a T-pose by the least rotation
        of each bone, the rest of the file's shape kept where it is plausible."""
        sk, U, L, F = self.sk, self.U, self.L, self.F
        R = [np.eye(3)] * self.n
        moved: dict[str, float] = {}
        reaimed: list[str] = []
        foot_pitch = None
        for j in range(self.n):
            nm = sk.names[j]
            base_role, side = self.rec.base_role(nm), self.rec.side(nm)
            p = int(sk.parents[j])
            base = R[p] if p >= 0 else np.eye(3)
            if j == self.pelvis:
                R[j] = R_pel @ base
                turn = float(np.degrees(Rotation.from_matrix(R_pel).magnitude()))
                if turn > 1e-9:
                    moved["pelvis"] = turn
                continue
            if base_role in ("ankle", "toe") and side and self.pelvis is not None:
                base = R[self.pelvis]
            v, target = self.bone(j)
            if v is None:
                R[j] = base
                continue
            vb = base @ v
            if base_role in ("hip", "knee", "shoulder", "elbow") and side:
                group = "legs" if base_role in ("hip", "knee") else "arms"
                moved[group] = max(moved.get(group, 0.0), _angle(vb, target))
                R[j] = swing(vb, target, F) @ base
                continue
            if j in self.spine_like:
                lr = self.lr_pair(j)
                lb = _unit(base @ lr) if lr is not None else None
                if _angle(vb, U) <= TRUNK_DEG and self.pair_ok(lb):
                    R[j] = base
                else:
                    reaimed.append(nm)
                    R[j] = (align(vb, U, lb, L, F) if lb is not None else swing(vb, U, F)) @ base
                continue
            if base_role == "ankle":
                ok = _foot_ok(U, F)(vb)
            elif base_role == "toe":
                ok = _toe_ok(U, F)(vb)
            elif base_role == "head":
                ok = _angle(vb, U) <= HEAD_DEG
            else:  # clavicle, wrist
                ok = _angle(vb, target) <= ARM_DEG
            if ok:
                R[j] = base
                continue
            reaimed.append(nm)
            if base_role == "ankle":
                if foot_pitch is None:
                    foot_pitch = _clip_foot_pitch(sk, self.rec, U, clip)
                target = _pitched(F, U, foot_pitch)
            R[j] = swing(vb, target, F) @ base
        return self._result(R, moved, reaimed, foot_pitch)

    def from_bones(self, R_pel: np.ndarray, clip: Clip | None) -> CanonicalRest:
        """A zero pose that is no human pose (bones along local axes): every segment with a
        role turned onto its canonical direction, with its twist about the bone (and every
        other joint's orientation) relative to its parent as in the clip's mean pose."""
        sk, U, L, F = self.sk, self.U, self.L, self.F
        mean_rel = _mean_relative(sk, clip)
        foot_pitch = None
        R = [np.eye(3)] * self.n
        reaimed: list[str] = []
        for j in range(self.n):
            nm = sk.names[j]
            p = int(sk.parents[j])
            if j == self.pelvis:
                R[j] = R_pel @ (R[p] if p >= 0 else np.eye(3))
                reaimed.append(nm)
                continue
            base = (R[p] if p >= 0 else np.eye(3)) @ mean_rel[j]
            v, target = self.bone(j)
            if v is None:
                R[j] = base
                continue
            reaimed.append(nm)
            vb = base @ v
            if self.rec.base_role(nm) == "ankle":
                if foot_pitch is None:
                    foot_pitch = _clip_foot_pitch(sk, self.rec, U, clip)
                target = _pitched(F, U, foot_pitch)
            lr = self.lr_pair(j) if j in self.spine_like else None
            if lr is not None:
                R[j] = align(vb, U, _unit(base @ lr), L, F) @ base
            else:
                R[j] = swing(vb, target, F) @ base
        out = self._result(R, {}, reaimed, foot_pitch)
        out.from_bones = True
        return out


#: degrees: a zero pose whose thighs, shanks and trunk are this close to down / up (seen from
#: the pelvis) is a human pose whose shape is kept
LEG_DEG = 45.0


def _pitched(F: np.ndarray, U: np.ndarray, pitch_deg: float) -> np.ndarray:
    pr = np.radians(pitch_deg)
    return np.cos(pr) * F - np.sin(pr) * U


def _mean_relative(sk: Skeleton, clip: Clip | None) -> list[np.ndarray]:
    """``(3, 3)`` per joint: the clip's mean orientation of each joint relative to its parent
    (the chordal mean of ``G_parent^-1 G_j``; identity for the root and without a clip)."""
    out = [np.eye(3)] * sk.n_joints
    if clip is None or clip.orientations is None:
        return out
    G = clip.orientations
    for j in range(1, sk.n_joints):
        p = int(sk.parents[j])
        m = Rotation.from_quat(G[:, p], scalar_first=True).inv() * \
            Rotation.from_quat(G[:, j], scalar_first=True)
        out[j] = m.mean().as_matrix()
    return out


def _foot_ok(U: np.ndarray, F: np.ndarray):
    lo, hi = FOOT_PITCH_DEG

    def ok(w: np.ndarray) -> bool:
        h = _unit(w - (w @ U) * U)
        if h is None:
            return False
        pitch = float(np.degrees(np.arcsin(np.clip(-(w @ U), -1.0, 1.0))))
        return _angle(h, F) <= FOOT_HEADING_DEG and lo <= pitch <= hi
    return ok


def _toe_ok(U: np.ndarray, F: np.ndarray):
    def ok(w: np.ndarray) -> bool:
        h = _unit(w - (w @ U) * U)
        if h is None:
            return False
        pitch = float(np.degrees(np.arcsin(np.clip(-(w @ U), -1.0, 1.0))))
        return _angle(h, F) <= FOOT_HEADING_DEG and abs(pitch) <= TOE_PITCH_DEG
    return ok


def _clip_foot_pitch(sk: Skeleton, rec: Recognition, U: np.ndarray, clip: Clip | None) -> float:
    """Degrees below level of the ankle-to-toe-joint line in the clip's flat stance: the median
    over the frames where each ankle is in the lowest quarter of its heights (the foot on the
    ground), both feet together; :data:`DEFAULT_FOOT_PITCH_DEG` without a clip or toes."""
    if clip is None:
        return DEFAULT_FOOT_PITCH_DEG
    pitches = []
    for s in ("left", "right"):
        a, t = rec.roles.get(f"{s}_ankle"), rec.roles.get(f"{s}_toe")
        if not (isinstance(a, str) and isinstance(t, str)):
            continue
        pa, pt = clip.positions[:, sk.index(a)], clip.positions[:, sk.index(t)]
        h = pa @ U
        low = h <= np.quantile(h, 0.25)
        d = pt[low] - pa[low]
        nrm = np.linalg.norm(d, axis=1)
        ok = nrm > 1e-12
        pitches += list(np.degrees(np.arcsin(np.clip(-(d[ok] @ U) / nrm[ok], -1.0, 1.0))))
    if not pitches:
        return DEFAULT_FOOT_PITCH_DEG
    return float(np.clip(np.median(pitches), 0.0, 60.0))
