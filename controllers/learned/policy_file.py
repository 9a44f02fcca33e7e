"""The policy file: a learned tracking policy that describes itself.

One ``.npz`` (numpy only to read) holding the network's arrays and a JSON document of metadata
under the key ``meta``:

- ``format``, ``version``: ``"mjchar-policy"``, 1;
- ``clip``: ``name`` (file or bundled name), ``hash`` (:func:`clip_hash` of the reference
  tracked), ``loop``, ``duration_s``, ``cyclic``;
- ``model``: ``fingerprint`` (:func:`~mjchar.controllers.sampling.trajectory.model_fingerprint`),
  ``nq``, ``nu``;
- ``observation``: ``size``, ``future_steps``, ``layout`` (named blocks ``[name, start, stop]``);
- ``action``: ``size``, ``scale_rad`` (``s`` of ``u = base + s * action``), ``base`` (how
  ``base`` is computed);
- ``env``: ``control_freq`` (Hz), ``n_substeps``, ``timestep`` (s): the control timing;
- ``network``: ``hidden``, ``activation``;
- ``training``: how it was learned (method, labels, wall time, measured figures).

Arrays (float32): ``mean``, ``std`` (input normalisation) and ``W0``, ``b0``, ``W1``, ...
(layers, PyTorch ``(out, in)`` layout); ``clip_bvh``: the text of the clip's BVH file.
:func:`load_policy` refuses a file that is not one, or a newer version, in one line
(:class:`PolicyError`); :meth:`Policy.check` refuses a model or a clip that is not the one it
was trained on.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mjchar.bvh.errors import MjcharError

from .mlp import MLP

__all__ = ["FORMAT", "VERSION", "Policy", "PolicyError", "clip_hash", "load_policy",
           "save_policy"]

FORMAT = "mjchar-policy"
VERSION = 1
#: samples of the reference hashed by :func:`clip_hash`
HASH_SAMPLES = 64


class PolicyError(MjcharError):
    """A policy file that cannot be read, or that was trained for another model or clip."""


def clip_hash(reference) -> str:
    """A short SHA-256 digest of what a tracker follows: the reference's duration, whether it
    loops, and its poses ``qpos`` at :data:`HASH_SAMPLES` evenly spaced times (rounded to 1e-5,
    so the same clip prepared the same way gives the same digest on any machine)."""
    T = float(reference.duration)
    q = np.asarray(reference.qpos(np.linspace(0.0, T, HASH_SAMPLES)), dtype=np.float64)
    h = hashlib.sha256()
    h.update(np.array([round(T, 6), float(bool(reference.cyclic))]).tobytes())
    h.update(np.round(q, 5).astype(np.float64).tobytes())
    return h.hexdigest()[:16]


@dataclass
class Policy:
    """A loaded policy: its network and its metadata (module docstring)."""

    net: MLP
    meta: dict
    path: str | None = field(default=None)
    arrays: dict = field(default_factory=dict)

    @property
    def name(self) -> str:
        return Path(self.path).stem if self.path else "policy"

    def clip_motion(self):
        """The clip it was trained on: its bundled name or file when present, else the copy of
        the BVH the file carries (a ``Motion``); ``None`` when neither."""
        from mjchar.bvh.bundled.assets import BUNDLED_MOTION_NAMES

        name = self.meta["clip"]["name"]
        if name in BUNDLED_MOTION_NAMES or os.path.isfile(name):
            return name
        text = self.arrays.get("clip_bvh")
        if text is None:
            return None
        from mjchar.bvh.io import loads

        return loads(str(text), path=name)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """``(nu,)`` action in [-1, 1] for observation ``obs``."""
        return np.clip(self.net(obs), -1.0, 1.0)

    def check(self, *, fingerprint: str | None = None, reference=None) -> None:
        """One-line :class:`PolicyError` when ``fingerprint`` (of the model it would drive) or
        ``reference`` (the clip it would track, compared by :func:`clip_hash`) is not the one
        it was trained on."""
        where = self.path or "the policy"
        if fingerprint is not None and fingerprint != self.meta["model"]["fingerprint"]:
            raise PolicyError(f"{where} was trained on another model (fingerprint "
                              f"{self.meta['model']['fingerprint'][:12]}, this model "
                              f"{fingerprint[:12]}): learn one for it with mjchar learn CLIP "
                              f"--model MODEL -o POLICY")
        if reference is not None:
            h = clip_hash(reference)
            clip = self.meta["clip"]
            if h != clip["hash"]:
                loop = " --loop" if clip.get("loop") else ""
                raise PolicyError(f"{where} was trained on clip {clip['name']}{loop} (hash "
                                  f"{clip['hash']}), not on this one ({h}): run it with "
                                  f"--motion {clip['name']}{loop}, or learn one for this clip")


def save_policy(path, net: MLP, meta: dict, clip_bvh: str | None = None) -> Path:
    """Write the policy file ``path`` atomically (a temporary file beside it, then moved);
    ``clip_bvh``: the text of the clip's BVH file, carried so the policy runs without it."""
    from mjchar.bvh.io.files import atomic_path

    path = Path(path)
    meta = dict(meta, format=FORMAT, version=VERSION)
    meta["network"] = dict(meta.get("network", {}), hidden=list(net.hidden), activation="elu")
    f32 = np.float32  # stored in single precision (half the size; inference is in double)
    arrays = {"meta": np.array(json.dumps(meta, sort_keys=True)), "mean": net.mean.astype(f32),
              "std": net.std.astype(f32)}
    for i, (w, b) in enumerate(zip(net.weights, net.biases, strict=True)):
        arrays[f"W{i}"], arrays[f"b{i}"] = w.astype(f32), b.astype(f32)
    if clip_bvh is not None:
        arrays["clip_bvh"] = np.array(clip_bvh)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **arrays)
    return path


def load_policy(path) -> Policy:
    """Read a policy file (numpy only); a file that is not one is one :class:`PolicyError`."""
    p = os.fspath(path)
    if not os.path.isfile(p):
        raise PolicyError(f"{p}: no such policy file")
    try:
        with np.load(p, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            n = sum(1 for k in z.files if k.startswith("W"))
            net = MLP([z[f"W{i}"] for i in range(n)], [z[f"b{i}"] for i in range(n)],
                      z["mean"], z["std"])
            extra = {k: z[k] for k in ("clip_bvh",) if k in z.files}
    except (OSError, ValueError, KeyError, json.JSONDecodeError) as e:
        raise PolicyError(f"{p}: not an mjchar policy file ({type(e).__name__}: "
                          f"{str(e).splitlines()[0] if str(e) else 'unreadable'})") from None
    if meta.get("format") != FORMAT:
        raise PolicyError(f"{p}: not an mjchar policy file (format {meta.get('format')!r})")
    if int(meta.get("version", 0)) > VERSION:
        raise PolicyError(f"{p}: policy file version {meta['version']} is newer than this "
                          f"mjchar reads ({VERSION}): upgrade mjchar")
    if net.n_in != meta["observation"]["size"] or net.n_out != meta["action"]["size"]:
        raise PolicyError(f"{p}: the network ({net.n_in} -> {net.n_out}) does not match its "
                          f"metadata ({meta['observation']['size']} -> {meta['action']['size']})")
    return Policy(net, meta, p, extra)
