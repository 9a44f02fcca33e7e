"""The joint-angle curves of gait analyses over the normalised gait cycle, as a PNG (matplotlib,
Agg backend; the ``bench`` extra)."""

from __future__ import annotations

import os

import numpy as np

from mjchar.bvh.errors import MjcharError

#: curves plotted, with their axis labels
PANELS = (("left_knee_flexion", "knee flexion (deg)"), ("left_hip_flexion", "hip flexion (deg)"),
          ("trunk_lean", "trunk lean (deg)"), ("pelvis_rotation", "pelvis rotation (deg)"))


def _pyplot():
    """``matplotlib.pyplot`` on the Agg backend, or a clear error naming the extra."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise MjcharError('plotting needs matplotlib: pip install "mjchar[bench]"') from None
    return plt


def _save(plt, fig, path, dpi: int) -> None:
    from mjchar.bvh.io.files import atomic_path

    fig.tight_layout()
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi)
    except OSError as e:
        raise MjcharError(f"cannot write {os.fspath(path)}: {e.strerror or e}") from None
    finally:
        plt.close(fig)


def plot_cycles(stats: list, path: str | os.PathLike) -> None:
    """One panel per curve of :data:`PANELS`: each walk's mean over its strides (a band of one
    standard deviation) against 0-100 % of the gait cycle (left foot strike to left foot
    strike)."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(PANELS), figsize=(4.2 * len(PANELS), 3.4))
    for ax, (key, label) in zip(axes, PANELS, strict=True):
        for s in stats:
            if key not in s.cycle_mean:
                continue
            m, sd = np.asarray(s.cycle_mean[key]), np.asarray(s.cycle_std[key])
            x = np.linspace(0.0, 100.0, len(m))
            line, = ax.plot(x, m, label=f"{s.label} ({s.strides} strides)")
            ax.fill_between(x, m - sd, m + sd, color=line.get_color(), alpha=0.2)
        ax.set_xlabel("gait cycle (%)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    if axes[0].get_legend_handles_labels()[0]:
        axes[0].legend(fontsize=7)
    _save(plt, fig, path, dpi=110)


#: frames per row of :func:`plot_filmstrip`
FILMSTRIP_FRAMES = 8


def stride_window(stats, times) -> tuple[float, float]:
    """``(t0, t1)``: the middle whole stride (left strike to left strike) of a walk, or, with
    fewer than two left strikes, the last second of its window (a clip too short to stride)."""
    strikes = list(getattr(stats, "left_strikes", []) or [])
    if len(strikes) >= 2:
        k = (len(strikes) - 2) // 2
        return strikes[k], strikes[k + 1]
    t1 = float(times[-1])
    return max(float(times[0]), t1 - 1.0), t1


def plot_filmstrip(walks: list, path: str | os.PathLike, frames: int = FILMSTRIP_FRAMES) -> None:
    """One row per walk, ``frames`` side views evenly over one stride (:func:`stride_window`),
    so a simulated walk can be set against the mocap's pose for pose.

    ``walks``: ``(stats, model, times, qpos)`` tuples (a
    :class:`~mjchar.bvh.gait.analysis.GaitStats` and the trajectory it was measured on). Rendering
    needs OpenGL (``MUJOCO_GL=egl`` headless)."""
    plt = _pyplot()
    from .render import render_poses

    rows = []
    for stats, model, times, qpos in walks:
        times, qpos = np.asarray(times, dtype=float), np.asarray(qpos, dtype=float)
        t0, t1 = stride_window(stats, times)
        at = t0 + (t1 - t0) * np.arange(frames) / frames
        idx = np.clip(np.searchsorted(times, at), 0, len(times) - 1)
        travel = qpos[idx[-1], :2] - qpos[idx[0], :2]
        heading = float(np.degrees(np.arctan2(travel[1], travel[0])))
        images = render_poses(model, qpos[idx], azimuth=90.0 + heading)
        rows.append((stats, at - t0, images))
    fig, axes = plt.subplots(len(rows), frames, figsize=(1.25 * frames, 2.1 * len(rows)),
                             squeeze=False)
    for ax_row, (stats, rel, images) in zip(axes, rows, strict=True):
        for ax, dt, img in zip(ax_row, rel, images, strict=True):
            ax.imshow(img)
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_xlabel(f"{dt:.2f} s", fontsize=7)
        speed = f"{stats.speed_mps:.2f} m/s"
        ax_row[0].set_ylabel(f"{stats.label}\n{speed}", fontsize=8)
    _save(plt, fig, path, dpi=100)
