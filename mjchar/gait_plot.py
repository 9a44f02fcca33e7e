"""The joint-angle curves of gait analyses over the normalised gait cycle, as a PNG (matplotlib,
Agg backend; the ``bench`` extra)."""

from __future__ import annotations

import os

import numpy as np

from bvh.errors import MjcharError

#: curves plotted, with their axis labels
PANELS = (("left_knee_flexion", "knee flexion (deg)"), ("left_hip_flexion", "hip flexion (deg)"),
          ("trunk_lean", "trunk lean (deg)"))


def plot_cycles(stats: list, path: str | os.PathLike) -> None:
    """One panel per curve of :data:`PANELS`: each walk's mean over its strides (a band of one
    standard deviation) against 0-100 % of the gait cycle (left foot strike to left foot
    strike)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise MjcharError('plotting needs matplotlib: pip install "mjchar[bench]"') from None
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
    fig.tight_layout()
    try:
        fig.savefig(path, dpi=110)
    except OSError as e:
        raise MjcharError(f"cannot write {os.fspath(path)}: {e.strerror or e}") from None
    finally:
        plt.close(fig)
