"""``mjchar calibrate MODEL``: fit the walkers' body-dependent parameters to a converted body
ahead of its runs (:mod:`mjchar.controllers.walking.calibration`), and store the result where
``mjchar run ipm|simbicon --model MODEL`` finds it."""

from __future__ import annotations

import argparse

from . import command_parser
from .argtypes import integer, non_negative


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``calibrate`` subcommand to ``mjchar``'s subparsers."""
    from mjchar.controllers.walking.calibration import BUDGET_S, CHECK_DURATION, WALKERS

    p = command_parser(
        sub, "calibrate",
        description="Fit the walkers' body-dependent parameters to a converted body: the "
                    "defaults are checked on short walks at three speeds; a body that passes "
                    "keeps them, one that fails gets a CMA-ES search (at most --budget seconds "
                    "per walker). The result is stored keyed by the model's physics fingerprint "
                    "in the cache ($MJCHAR_CACHE/calibration, else ~/.cache/mjchar/"
                    "calibration), where every run of the walker on that body finds it; a run "
                    "on a body with none calibrates it first. The bundled humanoid's "
                    "calibration is its defaults.")
    p.add_argument("model", metavar="MODEL.xml", help="a converted model (mjchar convert)")
    p.add_argument("--walker", choices=WALKERS + ("all",), default="all",
                   help="the walker to calibrate (default: all, " + " and ".join(WALKERS) + ")")
    p.add_argument("--budget", type=non_negative("budget"), default=BUDGET_S, metavar="S",
                   help=f"seconds for the calibration of the body, the checks included, "
                        f"shared by the walkers asked for (default {BUDGET_S:g}); the search "
                        "stops before a generation that would not fit")
    p.add_argument("--duration", type=non_negative("duration"), default=CHECK_DURATION,
                   metavar="S", help="simulated seconds per walk of the check and the search "
                                     f"(default {CHECK_DURATION:g})")
    p.add_argument("--jobs", type=integer("jobs", minimum=1), metavar="N",
                   help="worker processes (default: every core)")
    p.add_argument("-o", "--output", metavar="FILE.json",
                   help="write the calibration here instead of the cache (one walker only; "
                        "mjchar run takes it as --calibration FILE)")
    p.add_argument("--force", action="store_true",
                   help="calibrate again even if the cache has a calibration for this body")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object per walker (no progress)")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Calibrate each walker asked for; print what it changed."""
    import json
    import time

    from mjchar.bvh.errors import MjcharError
    from mjchar.bvh.io.files import check_output
    from mjchar.controllers.core.builder import check_model_file
    from mjchar.controllers.core.character import Character
    from mjchar.controllers.walking import calibration as cal_mod
    from mjchar.progress import Progress

    walkers = cal_mod.WALKERS if args.walker == "all" else (args.walker,)
    if args.output is not None:
        if len(walkers) > 1:
            raise MjcharError("-o takes one walker's calibration: give --walker ipm or simbicon")
        check_output(args.output, inputs=[args.model], flag="-o", suffixes=(".json",))
    check_model_file(args.model)
    ch = Character(args.model)
    if cal_mod.is_bundled(ch.model):
        print("the bundled humanoid: its calibration is the walkers' defaults (nothing to do)")
        return 0
    for walker in walkers:
        path = cal_mod.cache_path(ch.model, walker)
        if args.output is None and path.exists() and not args.force:
            cal = cal_mod.load(path)
            if cal_mod.is_current(cal):
                _report(args, cal, path, cached=True, json_mod=json)
                continue  # (one made by an earlier procedure is made again)
        bar = None if args.json else Progress(desc=f"calibrating {walker}")
        start = time.monotonic()
        if bar is not None:
            bar.start(args.budget / len(walkers), unit="s")

        def line(text: str, bar=bar, start=start, walker=walker) -> None:
            if bar is not None:
                bar(f"{walker}: {text}")
                bar.update(time.monotonic() - start)

        try:
            cal = cal_mod.calibrate(ch.model, walker, info=ch.info,
                                    budget_s=args.budget / len(walkers),
                                    jobs=args.jobs, duration=args.duration, progress=line)
        finally:
            if bar is not None:
                bar.close()
        written = cal_mod.save(cal, args.output)
        _report(args, cal, written, cached=False, json_mod=json)
    return 0


def _report(args, cal, path, *, cached: bool, json_mod) -> None:
    if args.json:
        print(json_mod.dumps({"model": args.model, "file": str(path), "cached": cached,
                              **json_mod.loads(cal.to_json())}))
        return
    what = {"defaults": "the defaults pass the check (no change)",
            "optimised": f"optimised: cost {cal.cost_defaults:.2f} -> {cal.cost:.2f}",
            "unimproved": "no better parameters found within the budget (the defaults kept)"}
    print(f"{cal.walker}: {what[cal.status]}; {cal.evaluations} candidate(s) in "
          f"{cal.seconds:.0f} s on {cal.jobs} process(es){' (cached)' if cached else ''}")
    if cal.status == "optimised":
        from mjchar.controllers.walking import calibration as cal_mod

        held = (f"held {cal_mod.CONFIRM_DURATION:.0f} s walks" if cal.confirmed
                else f"not confirmed by {cal_mod.CONFIRM_DURATION:.0f} s walks")
        print(f"  {held}; {len(cal.rejected)} candidate(s) ruled out by falls in them")
    for name, value in cal.overrides.items():
        shown = (f"[{', '.join(f'{v:.4g}' for v in value)}]" if isinstance(value, list)
                 else f"{value:.4g}")
        print(f"  {name} = {shown}")
    print(f"  stored: {path}")
