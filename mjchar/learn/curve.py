"""The learning curve as a picture: tracking error and fall rates (on the clip; pushed or
perturbed) of the learner against wall time, DAgger's iterations then PPO's evaluations
(matplotlib, imported here only)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["plot_curve"]


def plot_curve(rows: list[dict], path) -> Path | None:
    """Write the curve of ``rows`` (:func:`~mjchar.learn.dagger.learn`'s per-iteration rows) as
    a PNG at ``path`` (atomically); ``None`` and nothing written when matplotlib is absent (the
    picture is optional: a learning run goes on without it)."""
    try:
        import matplotlib
    except ImportError:
        return None

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mjchar.bvh.io.files import atomic_path

    minutes = [r["wall_s"] / 60.0 for r in rows]
    fig, ax = plt.subplots(figsize=(6, 3.6), dpi=100)
    ax.plot(minutes, [100 * r["eval_error_m"] for r in rows], "o-", color="tab:blue",
            label="tracking error")
    ax.set_xlabel("wall time (min)")
    ax.set_ylabel("mean joint error (cm)", color="tab:blue")
    ax2 = ax.twinx()
    ax2.plot(minutes, [r["eval_fall_rate"] for r in rows], "s--", color="tab:red",
             label="fall rate on the clip")
    if any("disturbed_fall_rate" in r for r in rows):
        ax2.plot(minutes, [r.get("disturbed_fall_rate", float("nan")) for r in rows], "^:",
                 color="tab:orange", label="fall rate, pushed or perturbed")
    ax2.set_ylabel("fall rate of the evaluation episodes", color="tab:red")
    ax2.legend(loc="center right", fontsize="small")
    ax2.set_ylim(-0.05, 1.05)
    rl = [m for m, r in zip(minutes, rows, strict=True) if r.get("stage") == "rl"]
    if rl:
        ax.axvline(rl[0], color="tab:gray", ls=":", label="PPO fine-tuning from here")
        ax.legend(loc="upper right", fontsize="small")
    ax.set_title("mjchar learn: the learner alone, after each iteration")
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
    return path
