"""The bench report: the table rows from a results document, the expectations check, the
terminal and Markdown tables, the performance summary and the video stills."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .config import DIRECTION_NAMES
from .matrix import expected_cells


def _protocol(scenario: str) -> bool:
    from mjchar.controllers.core.scenarios import registry

    return scenario in registry.names() and registry.get(scenario).protocol

def table_rows(doc: dict) -> list[dict]:
    """One row per controller: survival, largest push per direction, distance, speed, tracking
    error, root-force effort, step cost ratio (see docs/bench.md for where each comes from)."""
    rows = []
    costs = (doc.get("performance") or {}).get("cost") or {}
    costs = costs.get("controllers", {}) if costs.get("available") else {}
    for name, info in doc["controllers"].items():
        cells = {c["scenario"]: c for c in doc["cells"] if c["controller"] == name}
        row = {"controller": name, "label": info["label"], "available": info["available"],
               "reason": info["reason"], "survived": None, "runs": None, "fell": [],
               "errors": [f"{s}: {c['reason']}" for s, c in cells.items()
                          if c["status"] == "error"],
               "max_push_by_direction_N": None, "push_90_by_direction_N": None,
               "push_at_cap": None, "falls_unpushed": None, "push_protocol": None,
               "distance_m": None,
               "speed_mps": None, "motion_source": None, "tracking_error_m": None,
               "root_force_mean_N": None, "step_cost_ratio": None}
        # every cell's runs count in the survival column but a protocol's (a measurement)
        surv = [c for s, c in cells.items() if not _protocol(s) and c["status"] == "ok"]
        if surv:
            row["survived"] = sum(c["summary"]["survived"] for c in surv)
            row["runs"] = sum(c["summary"]["runs"] for c in surv)
            row["fell"] = [f"{c['scenario']} ({v})" for c in surv for v in c["summary"]["fell"]]
            forces = [r["result"]["root_force_mean_N"] for c in surv for r in c["runs"]]
            row["root_force_mean_N"] = float(np.mean(forces)) if forces else None
        ps = cells.get("push-search")
        if ps is not None and ps["status"] == "ok":
            for key in ("max_push_by_direction_N", "push_90_by_direction_N", "push_at_cap",
                        "falls_unpushed", "push_protocol"):
                row[key] = ps["summary"][key]
        for src in ("walk", "track"):
            c = cells.get(src)
            if c is not None and c["status"] == "ok" and c["runs"]:
                row["distance_m"] = c["summary"]["distance_m"]
                row["speed_mps"] = c["summary"]["speed_mps"]
                row["motion_source"] = src
                break
        tr = cells.get("track")
        if tr is not None and tr["status"] == "ok":
            row["tracking_error_m"] = tr["summary"]["tracking_error_m"]
        cost = costs.get(name)
        if cost and cost.get("available"):
            row["step_cost_ratio"] = cost["ratio"]
        rows.append(row)
    return rows


def check_expectations(doc: dict, expected: tuple[tuple[str, str], ...] | None = None
                       ) -> list[dict]:
    """Each expected cell (:func:`~mjchar.bench.matrix.expected_cells`) among the run's
    controllers: ``{"controller", "scenario", "status": "pass" | "fail" | "skipped",
    "detail"}``. ``fail``: a run fell or the
    cell raised; ``skipped``: the controller is not available or the cell was not selected."""
    cells = {(c["controller"], c["scenario"]): c for c in doc["cells"]}
    out = []
    for name, scenario in expected_cells() if expected is None else expected:
        c = cells.get((name, scenario))
        if c is None:
            status, detail = "skipped", "not selected"
        elif c["status"] == "not available":
            status, detail = "skipped", f"not available: {c['reason']}"
        elif c["status"] == "error":
            status, detail = "fail", f"error: {c['reason']}"
        elif c["summary"]["survived"] < c["summary"]["runs"]:
            fell = [r for r in c["runs"] if not r["survived"]]
            status = "fail"
            detail = "; ".join(f"{r['variant']}: fell at {_num(r['result']['fall_time_s'])} s "
                               f"({r['result']['fall_reason']})" for r in fell)
        else:
            status, detail = "pass", f"{c['summary']['runs']} run(s) without a fall"
        out.append({"controller": name, "scenario": scenario, "status": status,
                    "detail": detail})
    return out


def _num(x, fmt: str = ".2f") -> str:
    return "-" if x is None else format(x, fmt)


def _push_text(row: dict) -> str:
    """``F/L/B/R`` largest forces with survival rate 100 % (``>=`` at the grid's cap), ``w``
    pushed while walking, ``s`` stepping allowed; ``falls unpushed`` when it does."""
    if row["falls_unpushed"]:
        return "falls unpushed"
    p = row["max_push_by_direction_N"]
    if not p:
        return "-"
    cap = row["push_at_cap"] or {}
    text = "/".join((">=" if cap.get(d) else "") + f"{p[d]:.0f}" if d in p else "-"
                    for d in DIRECTION_NAMES)
    proto = row["push_protocol"] or ""
    if "walking" in proto:
        text += " w"
    elif "no step" not in proto:
        text += " s"
    return text


TABLE_HEADER = ("controller", "survival", "push 100% F/L/B/R (N)", "distance (m)",
                "speed (m/s)", "track err (m)", "root force (N)", "cost / mj_step")


def _cells(row: dict) -> list[str]:
    if not row["available"]:
        return [row["controller"], "not available", "", "", "", "", "", ""]
    surv = "-" if row["runs"] is None else f"{row['survived']}/{row['runs']}"
    if row["errors"]:
        surv += " (error)"
    dist = _num(row["distance_m"])
    if row["distance_m"] is not None and row["motion_source"] == "track":
        dist += " t"
    return [row["controller"], surv, _push_text(row), dist, _num(row["speed_mps"]),
            _num(row["tracking_error_m"], ".3f"), _num(row["root_force_mean_N"], ".0f"),
            _num(row["step_cost_ratio"])]


TABLE_NOTES = (
    "survival: runs without a fall over stand, random-push, walk, track and slopes runs.",
    "push 100%: per direction (forward/left/backward/right), the largest force of the grid up "
    "to which every force was survived in every run (all phases x seeds; protocols below); "
    ">=: the grid's cap; w: pushed while walking; s: stepping allowed; falls unpushed: the "
    "controller falls in the same window without a push, so it has no push figure.",
    "distance, speed: the walk scenario (steady speed over the last seconds), t: the track "
    "scenario instead. track err: mean joint position error against the reference.",
    "root force: mean external force on the root (hand of god) over the survival runs.",
    "cost / mj_step: controller + physics CPU time per physics step over a bare mj_step.",
)


def protocol_notes(rows: list[dict]) -> list[str]:
    """The push protocols of the table's rows, one line each (identical ones merged)."""
    seen: dict[str, list[str]] = {}
    for r in rows:
        if r.get("push_protocol"):
            seen.setdefault(r["push_protocol"], []).append(r["controller"])
    return [f"push protocol ({', '.join(names)}): {proto}." for proto, names in seen.items()]


def format_table(rows: list[dict]) -> str:
    """The terminal table (fixed-width columns), with the reasons of unavailable rows and the
    notes below it."""
    body = [list(TABLE_HEADER)] + [_cells(r) for r in rows]
    widths = [max(len(line[i]) for line in body) for i in range(len(TABLE_HEADER))]
    lines = []
    for k, line in enumerate(body):
        lines.append("  ".join(c.ljust(w) if i == 0 else c.rjust(w)
                               for i, (c, w) in enumerate(zip(line, widths, strict=True)))
                     .rstrip())
        if k == 0:
            lines.append("  ".join("-" * w for w in widths))
    for r in rows:
        if not r["available"]:
            lines.append(f"{r['controller']}: not available: {r['reason']}")
        for e in r["errors"]:
            lines.append(f"{r['controller']}: ERROR in {e}")
    lines.append("")
    lines.extend(TABLE_NOTES)
    lines.extend(protocol_notes(rows))
    return "\n".join(lines)


def markdown_table(rows: list[dict]) -> str:
    """The same table in Markdown (for the docs and the README)."""
    lines = ["| " + " | ".join(TABLE_HEADER) + " |", "|---" * len(TABLE_HEADER) + "|"]
    for r in rows:
        cells = _cells(r)
        if not r["available"]:
            cells[1] = f"not available ({r['reason']})"
        lines.append("| " + " | ".join(c.replace("|", "/") for c in cells) + " |")
    return "\n".join(lines)


def _raw_line(raw: dict) -> str:
    return (f"raw mj_step (dt {raw['timestep_s'] * 1e3:g} ms): "
            f"{raw['c_loop_steps_per_s']:,.0f} steps/s wall, "
            f"{raw['c_loop_steps_per_cpu_s']:,.0f} per CPU-second (C loop); "
            f"{raw['python_loop_steps_per_s']:,.0f} wall, "
            f"{raw['python_loop_steps_per_cpu_s']:,.0f} per CPU-second (Python loop)")


def _rollout_line(ro: dict) -> str:
    return ("batched rollouts (" + f"{ro['samples']} x {ro['steps_per_sample']} steps): "
            + ", ".join(f"{c['case']} {c['steps_per_s']:,.0f} steps/s "
                        f"({c['speedup_vs_python_loop']:.2f}x, {c['cores_busy']:.2f} "
                        f"cores busy)" for c in ro["cases"]))


def _cost_line(cost: dict) -> str:
    parts = [f"{n} {c['ratio']:.2f}x" for n, c in cost["controllers"].items()
             if c.get("available")]
    return "step cost / mj_step: " + (", ".join(parts) or "none available")


def _envs_line(env: dict) -> str:
    ref = env["reference"]
    return "env steps/s: " + ", ".join(
        f"{e} {v['env_steps_per_s']:,.0f} ({v['physics_steps_per_s']:,.0f} physics/s, "
        f"{env['ratios'][e]['physics_steps']:.2f}x {ref}'s physics rate)"
        for e, v in env["envs"].items())


def _bvh_line(bv: dict) -> str:
    return "BVH parse vs bvhio.readAsBvh: " + ", ".join(
        f"{f['file']} {f['bvh_load_ms']:.2f} vs {f['bvhio_ms']:.2f} ms ({f['speedup']:.1f}x)"
        for f in bv["files"])


def _envelope_line(en: dict) -> str:
    return "PD stability envelope (largest held step): " + ", ".join(
        f"{r['variant']} kp {r['kp']:g}: "
        + (f"1/{r['largest_held_hz']} s" if r["largest_held_hz"] else "none")
        for r in en["rows"])


#: the performance section's parts in print order: (key, its line, what a part that is not
#: available is called in its line saying so; ``None``: no line then)
_PERFORMANCE_LINES = (("raw", _raw_line, None), ("rollout", _rollout_line, "batched rollouts"),
                      ("cost", _cost_line, None), ("envs", _envs_line, "env throughput"),
                      ("bvh", _bvh_line, "BVH parse speed"), ("envelope", _envelope_line, None))


def format_performance(perf: dict) -> str:
    """A few readable lines of the performance section."""
    lines = []
    for key, line, name in _PERFORMANCE_LINES:
        part = perf.get(key) or {}
        if part.get("available"):
            lines.append(line(part))
        elif part and name:
            lines.append(f"{name}: not available: {part['reason']}")
    return "\n".join(lines)


STILL_PREFERENCE = (("simbicon", "walk"), ("ipm", "walk"), ("hand_of_god", "track"),
                    ("static_balance", "stand"))


def write_stills(out: Path, videos: list[dict]) -> list[str]:
    """A PNG of the middle frame of every video (``stills/NAME.png``) and ``still.png`` from the
    preferred cell (:data:`STILL_PREFERENCE`); returns the files written (relative to ``out``)."""
    import shutil

    import imageio.v2 as imageio

    d = out / "stills"
    d.mkdir(exist_ok=True)
    written = {}
    for v in videos:
        path = out / "videos" / v["file"]
        reader = imageio.get_reader(path)
        try:
            frame = reader.get_data(max(0, v["frames"] // 2))
        except (IndexError, ValueError):
            frame = reader.get_data(0)
        finally:
            reader.close()
        png = d / (Path(v["file"]).stem + ".png")
        imageio.imwrite(png, frame)
        written[(v["controller"], v["scenario"])] = png
    files = [str(p.relative_to(out)) for p in written.values()]
    for key in STILL_PREFERENCE + tuple(written):
        if key in written:
            shutil.copyfile(written[key], out / "still.png")
            files.append("still.png")
            break
    return files


