"""The gait section of ``mjchar bench``: every walker's walk and the mocap walks measured by one
probe (:mod:`mjchar.bvh.gait.analysis`), as a table and the gait-cycle plot (``gait_cycle.png``)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from .config import SHARED_BVH, BenchConfig

#: the analysed window starts here (s), after the walkers' start-up
GAIT_START_S = 3.0
#: the mocap walks compared with, when ../shared/data is present
MOCAP_WALKS = ("walk60.bvh", "walk_forward.bvh")


def gait_walks(config: BenchConfig, controllers: Sequence[str]) -> list[tuple[str, str, dict]]:
    """``(label, controller, factory options)`` of the gait section's walks: every walker among
    ``controllers`` at ``config.gait_speed`` if it takes a speed (the gait bars' comparison point,
    the mocap walks' speed), once per gait of ``config.gait_gaits`` if it takes a gait
    (labelled ``NAME GAIT``)."""
    from mjchar.controllers import registry

    out = []
    for name in controllers:
        spec = registry.get(name)
        if spec.kind != "walker":
            continue
        base = {"speed": config.gait_speed} if "speed" in spec.options else {}
        if "gait" in spec.options:
            out += [(f"{name} {g}", name, {**base, "gait": g}) for g in config.gait_gaits]
        else:
            out.append((name, name, base))
    return out


def run_gait(config: BenchConfig, controllers: Sequence[str], progress=None,
             filmstrip=None) -> dict:
    """Gait statistics of the walks of :func:`gait_walks` (``config.walk_duration`` s, analysed
    from :data:`GAIT_START_S`, or a quarter of the run if that is shorter; a run too short or
    fallen too early to analyse is listed in ``skipped``) and of the mocap walks. With
    ``filmstrip`` (a PNG path) every walk's middle stride is drawn there too
    (:func:`mjchar.gait_plot.plot_filmstrip`; ``filmstrip`` in the section names the file, or
    says why there is none)."""
    from mjchar.bvh.gait.analysis import GaitAnalysisError, analyse, clip_walk
    from mjchar.bvh.reference.export import MotionRecorder
    from mjchar.controllers.core.builder import RunSpec, execute

    start = min(GAIT_START_S, 0.25 * config.walk_duration)
    walks, falls, skipped = [], {}, {}
    for label, name, options in gait_walks(config, controllers):
        rec = MotionRecorder()
        run = RunSpec(name, "walk", options=options,
                      scenario_options={"duration": config.walk_duration}
                      ).build(frame_callback=rec)
        result = execute(run)
        ch = run.character
        falls[label] = result.fall_time_s
        try:
            walks.append((analyse(ch.model, rec.times, rec.qpos, start=start,
                                  end=result.fall_time_s, info=ch.info, label=label),
                          ch.model, rec.times, rec.qpos))
        except GaitAnalysisError as e:
            skipped[label] = str(e)
            continue
        if progress:
            progress(f"  gait {label}: {walks[-1][0].steps} steps")
    for clip in MOCAP_WALKS:
        if (SHARED_BVH / clip).is_file():
            model, info, times, qpos = clip_walk(SHARED_BVH / clip)
            stats = analyse(model, times, qpos, info=info, label=clip.removesuffix(".bvh"))
            walks.append((stats, model, times, qpos))
    section = {"start_s": start, "duration_s": config.walk_duration,
               "speed_mps": config.gait_speed, "falls": falls,
               "skipped": skipped, "walks": [w[0].to_dict() for w in walks]}
    if filmstrip is not None and walks:
        from mjchar.bvh.errors import MjcharError

        from ..gait_plot import plot_filmstrip

        try:
            plot_filmstrip(walks, filmstrip)
            section["filmstrip"] = Path(filmstrip).name
        except MjcharError as e:  # no OpenGL or no matplotlib: the numbers still stand
            section["filmstrip"] = f"not drawn: {e}"
    return section


def gait_markdown(section: dict | None) -> str:
    """The gait table (markdown), empty without a section."""
    if not section or not section.get("walks"):
        return ""
    from mjchar.bvh.gait.analysis import GaitStats, table

    stats = [GaitStats(**w) for w in section["walks"]]
    speed = section.get("speed_mps")
    at = f" at {speed:g} m/s" if speed is not None else ""
    return (f"Gait (walkers{at}: {section['duration_s']:g} s runs from {section['start_s']:g} s "
            "on; mocap clips whole; docs/gait.md):\n\n" + table(stats))


def plot_gait(section: dict | None, path):
    """``gait_cycle.png``: the cycle curves of every walk (None without a section)."""
    if not section or not section.get("walks"):
        return None
    from mjchar.bvh.gait.analysis import GaitStats

    from ..gait_plot import plot_cycles

    plot_cycles([GaitStats(**w) for w in section["walks"]], path)
    return path
