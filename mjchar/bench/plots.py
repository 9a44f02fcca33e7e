"""PNG plots of a ``mjchar bench`` document (matplotlib, Agg backend; the ``bench`` extra).

- ``push_search.png``: the push protocol's survival-rate curves against force, per direction.
- ``com_trajectories.png``: the walkers' centre of mass, top view (m) and height over time.
- ``tracking_error.png``: mean joint position error (m) over time for the trackers.
- ``stability_envelope.png``: which time steps each PD variant holds the pose at, per gain.
- ``step_cost.png``: each controller's cost per physics step over a bare ``mj_step``.

Every function takes the document (a dict, as written to ``results.json``) and a path, and
returns the path written, or ``None`` when the document has nothing to plot for it.
"""

from __future__ import annotations

import os
from pathlib import Path

from .config import DIRECTION_NAMES, BenchError

__all__ = ["require_matplotlib", "make_plots", "plot_push_search", "plot_com_trajectories",
           "plot_tracking_error", "plot_envelope", "plot_step_cost", "plot_walk_strip"]

_STATUS_COLOURS = {"held": "#4daf4a", "oscillates": "#ffb000", "diverged": "#d7301f",
                   "not scanned": "#f0f0f0"}


def require_matplotlib():
    """``matplotlib.pyplot`` with the Agg backend, or :class:`BenchError` saying how to get it."""
    try:
        import matplotlib
    except ImportError:
        raise BenchError("the bench plots need matplotlib: pip install 'mjchar[bench]' (or run "
                         "mjchar bench --no-plots)") from None
    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    from mjchar.bvh.io.files import atomic_path

    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, bbox_inches="tight")
    import matplotlib.pyplot as plt

    plt.close(fig)
    return path


def plot_push_search(doc: dict, path: str | os.PathLike) -> Path | None:
    """Survival-rate curves of the push protocol: one panel per direction, survival rate (over
    phases x seeds) against force (N), one line per controller; each panel marks the 100 %
    figure. Controllers that fall unpushed are listed in the title instead."""
    plt = require_matplotlib()
    cells = [c for c in doc["cells"] if c["scenario"] == "push-search" and c["status"] == "ok"
             and c["runs"] and "push" in c["runs"][0]]
    if not cells:
        return None
    measured = [c for c in cells if not c["runs"][0]["push"]["falls_unpushed"]]
    unpushed = [c["controller"] for c in cells if c["runs"][0]["push"]["falls_unpushed"]]
    dirs = [d for d in DIRECTION_NAMES if any(d in c["runs"][0]["push"]["curves"]
                                              for c in measured)] or list(DIRECTION_NAMES)
    fig, axes = plt.subplots(1, len(dirs), figsize=(3.3 * len(dirs) + 1.5, 3.6), sharey=True,
                             squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, d in zip(axes[0], dirs, strict=True):
        for k, c in enumerate(measured):
            push = c["runs"][0]["push"]
            curve = push["curves"].get(d)
            if not curve or not curve["forces_N"]:
                continue
            colour = colours[k % len(colours)]
            ax.plot(curve["forces_N"], [100 * r for r in curve["rates"]], "o-", ms=3,
                    color=colour, label=c["controller"])
            best = push["largest_100_N"][d]
            if best > 0:
                ax.axvline(best, color=colour, alpha=0.35, lw=1, ls="--")
        ax.set_title(d, fontsize=10)
        ax.set_xlabel("push force (N)")
        ax.set_ylim(-5, 105)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("survival rate (%)")
    handles, labels = axes[0][0].get_legend_handles_labels()
    for ax in axes[0][1:]:
        h, lab = ax.get_legend_handles_labels()
        for hh, ll in zip(h, lab, strict=True):
            if ll not in labels:
                handles.append(hh)
                labels.append(ll)
    if handles:
        fig.legend(handles, labels, fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5))
    title = ("Push protocol: survival rate of 0.2 s pushes over phases x seeds, per direction "
             "(dashed: the largest force with 100 %)")
    if unpushed:
        title += f"\nfall unpushed (no curve): {', '.join(unpushed)}"
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return _save(fig, Path(path))


def _walk_runs(doc: dict) -> list[tuple[str, dict]]:
    out = []
    for c in doc["cells"]:
        if c["scenario"] == "walk" and c["status"] == "ok":
            out.extend((c["controller"], r) for r in c["runs"] if r["series"]["t_s"])
    return out


def plot_com_trajectories(doc: dict, path: str | os.PathLike) -> Path | None:
    """The walkers' centre of mass: top view (x, y in m) and height (m) over time (s)."""
    plt = require_matplotlib()
    runs = _walk_runs(doc)
    if not runs:
        return None
    import numpy as np

    fig, (top, side) = plt.subplots(1, 2, figsize=(11, 4.2),
                                    gridspec_kw={"width_ratios": [1.4, 1]})
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    names = list(dict.fromkeys(n for n, _ in runs))
    styles = ["-", "--", ":", "-."]
    for n, r in runs:
        col = colours[names.index(n) % len(colours)]
        seeds = [rr["seed"] for nn, rr in runs if nn == n]
        ls = styles[seeds.index(r["seed"]) % len(styles)]
        com = np.asarray(r["series"]["com_m"])
        t = np.asarray(r["series"]["t_s"])
        label = (n + ("" if r["seed"] is None else f", seed {r['seed']}")
                 + (" (fell)" if not r["survived"] else ""))
        top.plot(com[:, 0], com[:, 1], ls, color=col, label=label)
        side.plot(t, com[:, 2], ls, color=col, label=label)
        if not r["survived"]:
            top.plot(com[-1, 0], com[-1, 1], "x", color=col, ms=9, mew=2)
            side.plot(t[-1], com[-1, 2], "x", color=col, ms=9, mew=2)
    top.set_xlabel("x (m, forward at the start)")
    top.set_ylabel("y (m, left)")
    top.set_title("Walkers' centre of mass, top view")
    top.set_aspect("equal", adjustable="datalim")
    top.grid(alpha=0.3)
    side.set_xlabel("time (s)")
    side.set_ylabel("centre of mass height (m)")
    side.set_title("Centre of mass height")
    side.grid(alpha=0.3)
    side.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    return _save(fig, Path(path))


def plot_tracking_error(doc: dict, path: str | os.PathLike) -> Path | None:
    """Mean joint position error (m) against the reference over time (s), one line per
    tracking controller (an x where it fell)."""
    plt = require_matplotlib()
    runs = [(c["controller"], r) for c in doc["cells"]
            if c["scenario"] == "track" and c["status"] == "ok" for r in c["runs"]
            if r["series"]["tracking_error_m"]]
    if not runs:
        return None
    import numpy as np

    fig, ax = plt.subplots(figsize=(8, 4.2))
    for n, r in runs:
        t = np.asarray(r["series"]["t_s"])
        e = np.asarray(r["series"]["tracking_error_m"], dtype=float)
        fell = not r["survived"]
        line, = ax.plot(t, e, label=f"{n}" + (f" (fell at {r['result']['fall_time_s']:.2f} s)"
                                               if fell else ""))
        if fell:
            ax.plot(t[-1], e[-1], "x", color=line.get_color(), ms=9, mew=2)
    ax.set_yscale("log")
    lo, hi = ax.get_ylim()
    ax.set_ylim(max(lo, 1e-3), hi)  # the first samples (on the reference) would stretch the axis
    ax.set_xlabel("time (s)")
    ax.set_ylabel("mean joint position error (m, log scale)")
    motion = Path(doc.get("track_motion") or "reference").name
    ax.set_title(f"Tracking error over time ({motion}; replays: their stored reference)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="lower right")
    return _save(fig, Path(path))


def plot_envelope(doc: dict, path: str | os.PathLike) -> Path | None:
    """Held / oscillates / diverged per PD variant and gain (rows) and time step (columns)."""
    plt = require_matplotlib()
    env = (doc.get("performance") or {}).get("envelope") or {}
    if not env.get("available") or not env.get("rows"):
        return None
    import numpy as np
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    rows = env["rows"]
    hzs = sorted({int(h) for r in rows for h in r["status"]}, reverse=True)
    order = list(_STATUS_COLOURS)
    grid = np.full((len(rows), len(hzs)), order.index("not scanned"))
    for i, r in enumerate(rows):
        for h, s in r["status"].items():
            grid[i, hzs.index(int(h))] = order.index(s)
    fig, ax = plt.subplots(figsize=(max(6.0, 0.55 * len(hzs) + 2.5), 0.42 * len(rows) + 1.8))
    ax.imshow(grid, cmap=ListedColormap([_STATUS_COLOURS[s] for s in order]), vmin=-0.5,
              vmax=len(order) - 0.5, aspect="auto")
    ax.set_xticks(range(len(hzs)), [f"1/{h}" for h in hzs], rotation=45, fontsize=8)
    ax.set_yticks(range(len(rows)), [f"{r['variant']}, kp {r['kp']:g}" for r in rows],
                  fontsize=8)
    for i, r in enumerate(rows):
        if r["largest_held_hz"]:
            j = hzs.index(int(r["largest_held_hz"]))
            ax.add_patch(plt.Rectangle((j - 0.42, i - 0.38), 0.84, 0.76, fill=False, lw=2.5,
                                       ec="black", zorder=3))
    ax.set_xticks(np.arange(len(hzs) + 1) - 0.5, minor=True)
    ax.set_yticks(np.arange(len(rows) + 1) - 0.5, minor=True)
    ax.grid(which="minor", color="white", lw=1)
    ax.tick_params(which="minor", length=0)
    ax.set_xlabel("physics time step (s)")
    ax.set_ylabel("PD variant, kp (N m/rad; kd = kp/10)")
    lim = "with" if env.get("torque_limits") else "torque limits lifted,"
    ax.set_title(f"PD stability envelope ({lim} root welded, {env['duration_s']:g} s; "
                 f"box: largest held step)", fontsize=10)
    ax.legend(handles=[Patch(color=_STATUS_COLOURS[s], label=s) for s in order],
              fontsize=8, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    return _save(fig, Path(path))


def plot_step_cost(doc: dict, path: str | os.PathLike) -> Path | None:
    """Bars: each controller's CPU cost per physics step over a bare ``mj_step``."""
    plt = require_matplotlib()
    cost = (doc.get("performance") or {}).get("cost") or {}
    if not cost.get("available"):
        return None
    items = [(n, c) for n, c in cost["controllers"].items() if c.get("available")]
    if not items:
        return None
    fig, ax = plt.subplots(figsize=(max(6.0, 0.9 * len(items) + 2), 3.8))
    bars = ax.bar([n for n, _ in items], [c["ratio"] for _, c in items], color="#4c72b0")
    ax.bar_label(bars, labels=[f"{c['ratio']:.2f}\n({c['timestep_s'] * 1e3:g} ms)"
                               for _, c in items], fontsize=7, padding=1)
    ax.axhline(1.0, color="black", lw=1, ls="--", label="bare mj_step = 1")
    ax.set_ylabel("CPU time per physics step / bare mj_step")
    ax.set_ylim(0, max(c["ratio"] for _, c in items) * 1.3)
    ax.set_title("Controller + physics cost per physics step (label: physics time step)")
    ax.tick_params(axis="x", labelrotation=30, labelsize=8)
    ax.legend(fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    return _save(fig, Path(path))


def make_plots(doc: dict, out_dir: str | os.PathLike) -> list[Path]:
    """Every plot the document has data for, written into ``out_dir``; returns the paths."""
    out = Path(out_dir)
    made = []
    for name, fn in (("push_search.png", plot_push_search),
                     ("com_trajectories.png", plot_com_trajectories),
                     ("tracking_error.png", plot_tracking_error),
                     ("stability_envelope.png", plot_envelope),
                     ("step_cost.png", plot_step_cost)):
        p = fn(doc, out / name)
        if p is not None:
            made.append(p)
    return made


#: the walkers whose walk video gives a row of :func:`plot_walk_strip`
STRIP_WALKERS = (("simbicon", "SIMBICON"), ("ipm", "IPM stepping"))


def plot_walk_strip(out: str | os.PathLike, videos: list[dict], *, fps: float, frames: int = 8,
                    spacing: float = 0.1, name: str = "walk_strip.png") -> Path | None:
    """A filmstrip of the walkers (one row per walker with a walk video in ``out/videos``):
    ``frames`` frames ``spacing`` s apart from the middle of the video, cropped to the character
    (the camera follows it), so alternating feet and the absence of skating can be seen."""
    import imageio.v2 as imageio

    plt = require_matplotlib()
    out = Path(out)
    rows = []
    for controller, label in STRIP_WALKERS:
        v = next((v for v in videos if v["controller"] == controller
                  and v["scenario"] == "walk"), None)
        if v is None:
            continue
        step = max(1, round(spacing * fps))
        first = max(0, v["frames"] // 2 - step * frames // 2)
        idx = [i for i in range(first, first + step * frames, step) if i < v["frames"]]
        reader = imageio.get_reader(out / "videos" / v["file"])
        try:
            images = [reader.get_data(i) for i in idx]
        finally:
            reader.close()
        rows.append((label, idx, images))
    if not rows:
        return None
    n = max(len(r[1]) for r in rows)
    fig, axes = plt.subplots(len(rows), n, figsize=(1.3 * n, 2.6 * len(rows)), squeeze=False)
    for ax_row, (label, idx, images) in zip(axes, rows, strict=True):
        for ax, i, img in zip(ax_row, idx, images, strict=False):
            h, w = img.shape[:2]
            ax.imshow(img[int(0.22 * h):int(0.86 * h), int(0.38 * w):int(0.62 * w)])
            ax.set_title(f"t = {i / fps:.1f} s", fontsize=8)
            ax.set_xticks([])
            ax.set_yticks([])
        for ax in ax_row[len(images):]:
            ax.axis("off")
        ax_row[0].set_ylabel(label)
    fig.suptitle(f"walk scenario, frames {spacing:g} s apart (camera follows the character)")
    return _save(fig, out / name)
