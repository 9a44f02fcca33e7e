"""The converter's geometry (step 3): capsules along the bones, boxes for feet and toes, sites.

:func:`_geometry` fills each body's geoms from its joint to its kept children (or end sites, or
its dropped children standing for the segment), with radii per role scaled by the standing
height (:data:`tables.RADIUS`); the trunk is a pair of capsules side by side; feet and toes are
boxes down to a shared sole level (:func:`_foot`, :func:`_toe`); head, hand, foot and toe sites
are placed. :func:`_floor_offset` puts the root above the origin and the lowest geom at ``z = 0``.
Lengths in metres, MuJoCo axes. Part of :func:`mjchar.bvh.mjcf.convert`.
"""

from __future__ import annotations

import math

import numpy as np

from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.mjcf import tables as T
from mjchar.bvh.mjcf.layout import _Body, _Geom
from mjchar.bvh.rigs.naming import Recognition


# ------------------------------------------------------------------------------------------------
# 3. geometry
# ------------------------------------------------------------------------------------------------
def _geometry(sk: Skeleton, rec: Recognition, sel: dict, bodies: dict[int, _Body],
              B: np.ndarray, scale: float) -> float:
    """Fill each body's geoms and sites; returns the top of the skeleton (m, before offset)."""
    rp = _RestPoints(sk, rec, sel, bodies, B, scale)
    s = rp.s
    sole = _sole_level(bodies, rp.subtree_points, s)
    for b in bodies.values():
        r = T.RADIUS.get(b.base, T.RADIUS["unknown"]) * s
        if b.base == "ankle" and b.side:
            _foot(b, bodies, rp.subtree_points, sole, s)
            continue
        if b.base == "toe" and b.side and b.parent in bodies and bodies[b.parent].base == "ankle":
            _toe(b, rp.subtree_points, rp.end_points(b), sole, s, bodies[b.parent])
            continue
        if b.parent < 0 and b.base != "pelvis":
            continue  # a reference root above the pelvis (e.g. on the floor): no geometry
        pts_b = _dedupe(rp.end_points(b), b.pos)
        if not pts_b:
            pts_b = _default_segment(b, bodies, s)
        _capsules(b, pts_b, r, s)
        _segment_sites(b, pts_b)
    _elbow_hand_sites(bodies)
    return float(rp.pts[:, 2].max())


class _RestPoints:
    """The rest pose in model axes (m) and the points each body's segment reaches.

    Attributes:
        rest: ``(J, 3)`` joint positions; ``ends``: ``(E, 3)`` end sites; ``pts``: both.
        s: the standing height over :data:`tables.REFERENCE_HEIGHT` (1 for a flat skeleton).
        site_body: kept body joint -> the end sites hanging in it (fused joints pass theirs on).
    """

    def __init__(self, sk: Skeleton, rec: Recognition, sel: dict, bodies: dict[int, _Body],
                 B: np.ndarray, scale: float) -> None:
        self.sk, self.rec, self.sel, self.bodies = sk, rec, sel, bodies
        self.rest = scale * sk.rest_positions() @ B.T
        self.ends = scale * sk.rest_end_sites() @ B.T if sk.n_end_sites else np.zeros((0, 3))
        self.pts = np.concatenate([self.rest, self.ends])
        height = float(self.pts[:, 2].max() - self.pts[:, 2].min())
        self.s = height / T.REFERENCE_HEIGHT if height > 0 else 1.0
        self.kids = _children_lists(sk)
        # where each end site hangs in the model (fused joints pass theirs on)
        self.site_body: dict[int, list[np.ndarray]] = {}
        for k in range(sk.n_end_sites):
            p = int(sk.end_site_parents[k])
            if p in sel["fused"]:
                p = sel["into"][p]
            if p in bodies:
                self.site_body.setdefault(p, []).append(self.ends[k])

    def subtree_points(self, j: int) -> np.ndarray:
        """``(n, 3)`` the joints and end sites below joint ``j``."""
        sk = self.sk
        idx = _descendants(self.kids, j)  # asked for a few joints only: each walk is linear
        inside = set(idx) | {j}
        e = [k for k in range(sk.n_end_sites) if int(sk.end_site_parents[k]) in inside]
        return (np.concatenate([self.rest[idx], self.ends[e]]) if (idx or e)
                else np.zeros((0, 3)))

    def end_points(self, b: _Body) -> list[np.ndarray]:
        """Where the segment of ``b`` ends: its kept children and end sites, else what its
        dropped children stand for; ``[]`` when nothing is far enough from its joint."""
        bodies, sk, s = self.bodies, self.sk, self.s
        out = [bodies[c].pos for c in b.children] + list(self.site_body.get(b.j, []))
        out = [p for p in out if np.linalg.norm(p - b.pos) > 0.005 * s]
        if out:
            return out
        # no kept children: the dropped children stand for the segment (e.g. fingers for a hand;
        # not a face for a head, whose capsule then rises from the joint)
        gone = [c for c in sk.children(b.j) if c in self.sel["removed"]
                and self.rec.joint_roles[sk.names[c]] != "face"]
        if gone:
            m = np.mean(self.rest[gone], axis=0)
            if np.linalg.norm(m - b.pos) > 0.005 * s:
                return [m]
            sub = np.concatenate([self.subtree_points(c) for c in gone] + [self.rest[gone]])
            far = sub[np.argmax(np.linalg.norm(sub - b.pos, axis=1))]
            if np.linalg.norm(far - b.pos) > 0.005 * s:
                return [far]
        return []


def _sole_level(bodies: dict[int, _Body], subtree_points, s: float) -> float | None:
    """The height of the soles, shared by both feet: below the lowest point under each ankle
    (``None`` without feet)."""
    feet = {b.side: b for b in bodies.values() if b.base == "ankle" and b.side}
    sole = None
    for b in feet.values():
        below = subtree_points(b.j)
        lo = float(below[:, 2].min()) if len(below) else b.pos[2]
        sole_b = lo - 0.025 * s if lo < b.pos[2] - 0.01 * s else b.pos[2] - 0.075 * s
        sole = sole_b if sole is None else min(sole, sole_b)
    return sole


def _capsules(b: _Body, pts_b: list[np.ndarray], r: float, s: float) -> None:
    """A capsule of radius ``r`` (thinner for helpers) from the joint of ``b`` to each end point
    (a head's rises from its joint); a vertical spine segment is a pair side by side."""
    for i, e in enumerate(pts_b):
        d = e - b.pos
        length = float(np.linalg.norm(d))
        u = d / length
        rr = r
        if b.base in ("unknown", "end", "hand", "face", "toes", "twist"):  # helpers: thin
            rr = min(r, 0.25 * length + 0.005 * s)
        if b.base == "head":
            a = b.pos + u * min(0.5 * length, rr)
            c = e - u * rr
            if (c - a) @ u < 0:
                a = c = b.pos + u * 0.5 * length
        else:
            k = min(rr, 0.3 * length)
            a, c = b.pos + u * k, e - u * k
        if float((c - a) @ u) < 0.002:  # MuJoCo needs distinct fromto points
            mid = 0.5 * (a + c)
            a, c = mid - 0.001 * u, mid + 0.001 * u
        gname = f"{b.name}_geom{i}" if i else f"{b.name}_geom"
        if b.base == "spine" and abs(u[2]) > 0.7:
            # the trunk is wider than deep: two capsules side by side (a flat back, so a
            # fallen character lies still instead of rolling on a round torso)
            side = np.array([0.0, T.TRUNK_PAIR_OFFSET * rr, 0.0])
            for tag, sgn in (("l", 1.0), ("r", -1.0)):
                b.geoms.append(_Geom("capsule", f"{gname}_{tag}", a=a + sgn * side,
                                     b=c + sgn * side, radius=T.TRUNK_PAIR_RADIUS * rr))
            continue
        b.geoms.append(_Geom("capsule", gname, a=a, b=c, radius=rr))


def _segment_sites(b: _Body, pts_b: list[np.ndarray]) -> None:
    """The head site (its capsule's middle) and a hand site (half way to the wrist's end)."""
    if b.base == "head":
        g = b.geoms[0]
        b.sites["head"] = 0.5 * (g.a + g.b)
    if b.base == "wrist" and b.side:
        e = pts_b[0]
        b.sites[f"{b.side}_hand"] = 0.5 * (b.pos + e)


def _elbow_hand_sites(bodies: dict[int, _Body]) -> None:
    """Hands without a recognised wrist: the site at the far end of the elbow's capsule."""
    for side in ("left", "right"):
        if not any(f"{side}_hand" in b.sites for b in bodies.values()):
            el = [b for b in bodies.values() if b.base == "elbow" and b.side == side]
            if el and el[0].geoms:
                g = el[0].geoms[0]
                el[0].sites[f"{side}_hand"] = g.b


def _children_lists(sk: Skeleton) -> list[list[int]]:
    """Each joint's children, ``(J,)`` lists, in one pass over the parents."""
    kids: list[list[int]] = [[] for _ in range(sk.n_joints)]
    for c, p in enumerate(sk.parents.tolist()):
        if p >= 0:
            kids[p].append(c)
    return kids


def _descendants(kids: list[list[int]], j: int) -> list[int]:
    """Joints below ``j``, sorted; ``kids`` from :func:`_children_lists`."""
    out, stack = [], list(kids[j])
    while stack:
        c = stack.pop()
        out.append(c)
        stack.extend(kids[c])
    return sorted(out)


def _dedupe(points: list[np.ndarray], origin: np.ndarray, max_angle_deg: float = 25.0):
    """Drop end points in (nearly) the same direction as a farther one."""
    pts = sorted(points, key=lambda p: -float(np.linalg.norm(p - origin)))
    kept: list[np.ndarray] = []
    cos_max = math.cos(math.radians(max_angle_deg))
    for p in pts:
        d = (p - origin) / np.linalg.norm(p - origin)
        if all(float(d @ ((q - origin) / np.linalg.norm(q - origin))) < cos_max for q in kept):
            kept.append(p)
    return kept


def _default_segment(b: _Body, bodies: dict[int, _Body], s: float) -> list[np.ndarray]:
    """A short segment for a body with nothing below it, along its parent bone."""
    if b.base == "head":
        return [b.pos + np.array([0.0, 0.0, 0.2 * s])]
    if b.parent >= 0:
        d = b.pos - bodies[b.parent].pos
        length = float(np.linalg.norm(d))
        if length > 1e-9:
            ext = {"wrist": 0.08 * s, "toe": 0.05 * s}.get(b.base, max(0.25 * length, 0.03 * s))
            return [b.pos + d / length * ext]
    return [b.pos + np.array([0.0, 0.0, 0.1 * s])]


def _yaw_frame(d: np.ndarray) -> tuple[np.ndarray, float]:
    h = np.array([d[0], d[1], 0.0])
    n = np.linalg.norm(h)
    u = h / n if n > 1e-9 else np.array([1.0, 0.0, 0.0])
    return u, math.atan2(u[1], u[0])


def _foot(b: _Body, bodies, subtree_points, sole: float, s: float) -> None:
    """Foot box from the heel to the toe joint (or the foot's end), from the sole to the ankle."""
    toe = [c for c in b.children if bodies[c].base == "toe"]
    if toe:
        front = bodies[toe[0]].pos
    else:
        pts = subtree_points(b.j)
        if len(pts):
            u0, _ = _yaw_frame(np.mean(pts, axis=0) - b.pos)
            front = pts[np.argmax((pts - b.pos) @ u0)]
        else:
            front = b.pos + np.array([0.15 * s, 0.0, 0.0])
    u, yaw = _yaw_frame(front - b.pos)
    reach = float((front - b.pos) @ u)
    if reach < 0.05 * s:
        reach = 0.12 * s
    heel = max(0.05 * s, 0.3 * reach)
    top = b.pos[2] if b.pos[2] - sole > 0.03 * s else sole + 0.05 * s
    half = np.array([0.5 * (reach + heel), T.RADIUS["ankle"] * s, 0.5 * (top - sole)])
    center = b.pos + u * (0.5 * (reach - heel))
    center = np.array([center[0], center[1], 0.5 * (top + sole)])
    b.geoms.append(_Geom("box", f"{b.name}_geom", center=center, half=half, yaw=yaw))
    b.sites[f"{b.side}_foot"] = np.array([center[0], center[1], sole])


def _toe(b: _Body, subtree_points, ends: list[np.ndarray], sole: float, s: float,
         ankle: _Body) -> None:
    """Toe box from the toe joint to the toe's end, from the sole up."""
    u, yaw = _yaw_frame(b.pos - ankle.pos)
    pts = list(ends) + list(subtree_points(b.j))
    reach = max([float((p - b.pos) @ u) for p in pts] + [0.0])
    if reach < 0.03 * s:
        reach = 0.05 * s
    top = sole + float(np.clip(2.0 * (b.pos[2] - sole), 0.02 * s, 0.05 * s))
    half = np.array([0.5 * reach, T.RADIUS["toe"] * s, 0.5 * (top - sole)])
    c = b.pos + u * 0.5 * reach
    center = np.array([c[0], c[1], 0.5 * (top + sole)])
    b.geoms.append(_Geom("box", f"{b.name}_geom", center=center, half=half, yaw=yaw))
    b.sites[f"{b.side}_toe"] = np.array([center[0], center[1], sole])


def _geom_top(bodies: dict[int, _Body]) -> float:
    """The highest point of any geom (m, before the floor offset); -inf without geoms."""
    tops = [float(max(g.a[2], g.b[2]) + g.radius) if g.kind == "capsule"
            else float(g.center[2] + g.half[2]) for b in bodies.values() for g in b.geoms]
    return max(tops, default=-np.inf)


def _floor_offset(bodies: dict[int, _Body]) -> np.ndarray:
    """Translation putting the root above the origin and the lowest geom on the floor (z=0)."""
    root = next(iter(bodies.values()))
    lows = [g.lowest() for b in bodies.values() for g in b.geoms]
    low = min(lows) if lows else min(b.pos[2] for b in bodies.values())
    return np.array([-root.pos[0], -root.pos[1], -low])

