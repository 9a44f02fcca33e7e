"""``run_bench``: the matrix, the performance section and the outputs (``results.json``, the
tables, plots, videos and stills) of one bench run, plus what reads a results document back
(:func:`physics_view`, :func:`exit_status`)."""

from __future__ import annotations

import copy
import json
import os
import platform
import resource
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mjchar.bvh.io.files import write_text
from mjchar.perf.timing import load_average

from .config import (
    REFERENCE_CORES,
    REFERENCE_STEPS_PER_S,
    ROOT,
    SCHEMA_NAME,
    SCHEMA_VERSION,
    TIMING_KEYS,
    BenchConfig,
    BenchError,
    json_ready,
    relative_path,
)
from .matrix import default_track_motion, find_trajectories, run_matrix, select_cells
from .parallel import default_jobs
from .performance import run_performance
from .report import (
    TABLE_NOTES,
    check_expectations,
    markdown_table,
    protocol_notes,
    table_rows,
    write_stills,
)


def versions() -> dict:
    """Versions of mjchar, MuJoCo, numpy, Python (and Gymnasium when installed)."""
    import mujoco

    out = {"mjchar": _mjchar_version(), "mujoco": mujoco.__version__, "numpy": np.__version__,
           "python": platform.python_version()}
    try:
        from importlib.metadata import version

        out["gymnasium"] = version("gymnasium")
    except Exception:
        out["gymnasium"] = None
    return out


def _mjchar_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("mjchar")
    except PackageNotFoundError:
        pass
    try:
        import tomllib

        with open(ROOT / "pyproject.toml", "rb") as f:
            return str(tomllib.load(f)["project"]["version"])
    except (OSError, KeyError, ValueError):
        return "unknown"


def run_bench(config: BenchConfig, *, controllers: Sequence[str] | None = None,
              scenarios: Sequence[str] | None = None, out_dir: str | os.PathLike | None = None,
              videos: bool = False, performance: bool = True, plots: bool = True,
              trajectories: dict[str, Path] | None = None, progress: bool = True,
              command: Sequence[str] | None = None, skeletons=None,
              matrix: bool = True, jobs: int | None = None) -> dict:
    """Run the matrix (and the performance section), write ``results.json``, the plots and the
    videos into ``out_dir`` (nothing is written when it is ``None``); returns the document.

    Args:
        config: :func:`quick_config` or :func:`full_config` (possibly replaced).
        controllers, scenarios: subsets (default: all); the cells are the matrix's among them.
        videos: one MP4 per cell (first run) plus a PNG still of its middle frame (needs
            ``MUJOCO_GL=egl`` and the video extra).
        performance: run the performance section (step-cost ratios of the selected
            controllers, raw and batched throughput, envs, BVH parsing, PD envelope).
        plots: write the PNG plots (needs matplotlib: the bench extra).
        trajectories: ``{"samcon_replay": path, "cmaes_replay": path}`` (default:
            :func:`find_trajectories`).
        skeletons: a :class:`~mjchar.bench.skeletons.SkeletonConfig` to add the skeletons
            section (every check on every zoo rig; the rigs and their models are written to
            ``out_dir/skeletons``), or ``None``.
        matrix: run the controller x scenario matrix (and with it the performance and gait
            sections); ``False`` with ``skeletons`` runs the skeletons section alone.
        jobs: worker processes of the matrix (default: one per core); the results do not
            depend on it.
    """
    config.check()
    t_start = time.perf_counter()
    cpu_start = _cpu_seconds()
    cells = select_cells(controllers, scenarios) if matrix else []
    if not matrix:
        performance = False
    trajectories = find_trajectories() if trajectories is None else dict(trajectories)
    out = None if out_dir is None else Path(out_dir)
    if out is not None:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise BenchError(f"cannot create the output folder {out}: {e}") from None
    if plots:
        from .plots import require_matplotlib

        require_matplotlib()  # fail now, not after the whole run
    video_dir = None
    if videos:
        if out is None:
            raise BenchError("videos need an output folder")
        video_dir = out / "videos"
        video_dir.mkdir(exist_ok=True)
    doc: dict = {
        "schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "command": list(command) if command is not None else None,
        "versions": versions(),
        "machine": {"platform": platform.platform(), "machine": platform.machine(),
                    "cpu_count": os.cpu_count(), "load_average_start": load_average()},
        "config": config.to_dict(), "seeds": [int(s) for s in config.seeds],
        "track_motion": relative_path(default_track_motion()),
    }
    t0 = time.perf_counter()
    jobs = default_jobs() if jobs is None else int(jobs)
    cells_cpu: dict[str, float] = {}
    doc["controllers"], doc["cells"], vids = run_matrix(
        cells, config, trajectories=trajectories, video_dir=video_dir, progress=progress,
        jobs=jobs, cpu=cells_cpu)
    for c in doc["cells"]:
        c["cpu_s"] = cells_cpu.get(f"{c['controller']} / {c['scenario']}", 0.0)
    timings = {"matrix_s": time.perf_counter() - t0, "jobs": jobs}
    doc["performance"] = None
    if performance:
        t0 = time.perf_counter()
        names = [n for n in doc["controllers"]]
        doc["performance"] = run_performance(names, config, trajectories=trajectories,
                                             progress=progress)
        timings["performance_s"] = time.perf_counter() - t0
    doc["gait"] = None
    from mjchar.controllers import registry

    if any(registry.get(n).kind == "walker" for n in doc["controllers"]):
        from .gait import run_gait

        t0 = time.perf_counter()
        strip = out / "gait_filmstrip.png" if out is not None and plots and videos else None
        doc["gait"] = run_gait(config, list(doc["controllers"]),
                               progress=print if progress else None, filmstrip=strip)
        timings["gait_s"] = time.perf_counter() - t0
    doc["skeletons"] = None
    if skeletons is not None:
        from .skeletons import public, run_skeletons

        t0 = time.perf_counter()
        doc["skeletons"] = public(run_skeletons(skeletons, out_dir=out,
                                                progress=print if progress else None))
        timings["skeletons_s"] = time.perf_counter() - t0
    doc["table"] = table_rows(doc)
    doc["expectations"] = check_expectations(doc)
    doc["videos"] = vids
    doc["stills"] = []
    doc["plots"] = []
    if out is not None:
        t0 = time.perf_counter()
        if videos and vids:
            doc["stills"] = write_stills(out, vids)
            if plots:
                from .plots import plot_walk_strip

                strip = plot_walk_strip(out, vids, fps=config.fps)
                if strip is not None:
                    doc["stills"].append(strip.name)
        if plots:
            from .plots import make_plots

            doc["plots"] = [p.name for p in make_plots(doc, out)]
            from .gait import plot_gait

            if plot_gait(doc["gait"], out / "gait_cycle.png") is not None:
                doc["plots"].append("gait_cycle.png")
            if doc["gait"] and doc["gait"].get("filmstrip") == "gait_filmstrip.png":
                doc["plots"].append("gait_filmstrip.png")
        from .gait import gait_markdown

        notes = TABLE_NOTES + tuple(protocol_notes(doc["table"]))
        from .skeletons import skeletons_markdown

        gait = gait_markdown(doc["gait"])
        rigs = skeletons_markdown(doc["skeletons"])
        write_text(out / "table.md", markdown_table(doc["table"]) + "\n\n"
                   + "\n".join(f"- {n}" for n in notes) + "\n"
                   + (f"\n{gait}\n" if gait else "") + (f"\n{rigs}\n" if rigs else ""))
        timings["outputs_s"] = time.perf_counter() - t0
    timings["cells"] = {f"{c['controller']} / {c['scenario']}": c["wall_s"]
                        for c in doc["cells"]}
    timings["cells_cpu"] = {f"{c['controller']} / {c['scenario']}": c["cpu_s"]
                            for c in doc["cells"]}
    doc["wall_s"] = time.perf_counter() - t_start
    timings["cpu_s"] = _cpu_seconds() - cpu_start
    timings["normalised"] = normalised(doc["wall_s"], timings["cpu_s"], doc["performance"])
    doc["timings"] = timings
    doc["machine"]["load_average_end"] = load_average()
    if out is not None:
        write_json(doc, out / "results.json")
    return doc


def _cpu_seconds() -> float:
    """CPU seconds (user + system) of this process and of its finished child processes."""
    own, kids = (resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def normalised(wall_s: float, cpu_s: float, performance: dict | None) -> dict:
    """The run's cost on the reference machine (:data:`~mjchar.bench.config.
    REFERENCE_STEPS_PER_S` bare ``mj_step``/s of the bundled humanoid on one core,
    :data:`~mjchar.bench.config.REFERENCE_CORES` cores): wall and CPU seconds scaled by this
    machine's bare rate over the reference's; ``cpu_per_core_s`` (CPU over the reference's
    cores) is what the run takes there with nothing else running. The bare rate is the
    performance section's C loop per CPU second, or a short measurement when it did not run."""
    raw = (performance or {}).get("raw") or {}
    rate = raw.get("c_loop_steps_per_cpu_s") if raw.get("available") else None
    if not rate:
        from mjchar.controllers.core import scenarios as S
        from mjchar.controllers.core.character import Character
        from mjchar.perf.physics import raw_step_rate

        ch = Character()
        rate = raw_step_rate(ch.model, S.standing_pose(ch), steps=2000,
                             repeats=3)["c_loop_steps_per_cpu_s"]
    scale = float(rate) / REFERENCE_STEPS_PER_S
    return {"reference_steps_per_s": REFERENCE_STEPS_PER_S, "reference_cores": REFERENCE_CORES,
            "bare_steps_per_s": float(rate), "wall_s": wall_s * scale,
            "cpu_s": cpu_s * scale, "cpu_per_core_s": cpu_s * scale / REFERENCE_CORES}


def write_json(doc: dict, path: str | os.PathLike) -> Path:
    """Write the document as JSON (non-finite numbers as ``null``), atomically."""
    return write_text(path, json.dumps(json_ready(doc), indent=1, allow_nan=False) + "\n")


def physics_view(doc: dict) -> dict:
    """The parts of a document that depend only on the physics (timings, dates, loads and the
    performance section removed): equal for equal seeds and settings."""
    cells = []
    for c in doc["cells"]:
        c = copy.deepcopy(c)
        c.pop("wall_s", None)
        c.pop("cpu_s", None)
        for r in c["runs"]:
            for k in TIMING_KEYS:
                r["result"].pop(k, None)
        cells.append(c)
    rows = [{k: v for k, v in r.items() if k != "step_cost_ratio"} for r in doc["table"]]
    return json_ready({"cells": cells, "table": rows, "expectations": doc["expectations"],
                   "seeds": doc["seeds"], "config": doc["config"]})


def exit_status(doc: dict) -> int:
    """0 when no expectation failed and every check of the skeletons section passed, else 1."""
    rigs = (doc.get("skeletons") or {}).get("rigs", [])
    failed = any(not c["ok"] for r in rigs for c in r["checks"].values())
    return 1 if failed or any(e["status"] == "fail" for e in doc["expectations"]) else 0


