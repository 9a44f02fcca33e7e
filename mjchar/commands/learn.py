"""``mjchar learn CLIP -o POLICY``: distil the sampling MPC into a tracking policy (DAgger with
DART noise, :mod:`mjchar.learn.dagger`); ``mjchar run policy POLICY`` runs the result."""

from __future__ import annotations

import argparse

from . import command_parser
from .argtypes import fraction, integer, positive


def register(sub: argparse._SubParsersAction) -> None:
    p = command_parser(
        sub, "learn",
        description="Distil the closed-loop sampling MPC into a network that tracks the clip "
                    "faster than real time: roll out the learner mixed with the MPC, with action "
                    "noise, perturbed starts and pushes; label the visited states with the MPC; "
                    "train on everything labelled so far; repeat; then fine-tune the best network "
                    "with PPO on mjchar/Imitation-v0 (--rl-share of the --minutes). "
                    "Writes POLICY (a self-describing .npz that `mjchar run policy POLICY` runs "
                    "with numpy only) after every iteration, a learning curve beside it "
                    "(POLICY stem + .curve.png / .curve.json) and the state --resume continues "
                    "from (.learn.pt). Training needs PyTorch: pip install torch==2.13.0.")
    p.add_argument("clip", metavar="CLIP", help="the clip: a BVH file or a bundled name (walk)")
    p.add_argument("-o", "--output", required=True, metavar="POLICY",
                   help="policy file to write (.npz)")
    p.add_argument("--minutes", type=positive("minutes"), default=60.0, metavar="M",
                   help="wall-clock budget (default 60)")
    p.add_argument("--seed", type=integer("seed"), default=0, metavar="N")
    p.add_argument("--model", metavar="FILE.xml", help="converted model (default: bundled)")
    p.add_argument("--no-loop", dest="loop", action="store_false",
                   help="track the clip once through instead of a seamless loop of it")
    p.add_argument("--workers", type=integer("workers", 1), metavar="N",
                   help="labelling workers (default: every core, or every CPU of the Ray "
                        "cluster)")
    p.add_argument("--executor", choices=("local", "ray"), default="local",
                   help="where the labelling runs: worker processes on this machine "
                        "(default) or Ray actors (needs the ray extra)")
    p.add_argument("--ray-address", metavar="ADDR",
                   help="Ray cluster (host:port, ray://host:port, auto); default: start a "
                        "local Ray instance (with --executor ray)")
    p.add_argument("--label-samples", type=integer("label samples", 2), default=16,
                   metavar="N", help="MPC candidates per label (default 16; the MPC's own "
                                     "default is 48)")
    p.add_argument("--label-nominal", choices=("plan", "learner"), default="plan",
                   help="what a label is warm started from: the MPC's previous plan in the "
                        "episode (default) or the learner's own action")
    p.add_argument("--episode-seconds", type=positive("episode seconds"), default=4.0,
                   metavar="S", help="simulated seconds per DAgger episode (default 4)")
    p.add_argument("--episodes", type=integer("episodes", 1), metavar="N",
                   help="episodes per iteration (default: one per worker)")
    p.add_argument("--noise", type=fraction("noise"), default=0.1, metavar="SD",
                   help="DART action noise, in scaled action units (default 0.1)")
    p.add_argument("--future-steps", type=integer("future steps", 0), default=1, metavar="K",
                   help="reference poses 1..K control steps ahead in the observation "
                        "(default 1)")
    p.add_argument("--rl-share", type=fraction("rl share"), default=0.5, metavar="F",
                   help="share of the budget spent fine-tuning the distilled network with PPO "
                        "after DAgger (default 0.5; 0: DAgger only; needs stable-baselines3)")
    p.add_argument("--perturb-rate", type=fraction("perturb rate"), default=0.3, metavar="F",
                   help="share of training episodes from a perturbed start (default 0.3)")
    p.add_argument("--push-rate", type=fraction("push rate"), default=0.3, metavar="F",
                   help="share of training episodes with one horizontal push in a random "
                        "direction (default 0.3)")
    p.add_argument("--validate-perturbed", type=integer("validate perturbed", 0), default=0,
                   metavar="N", help="perturbed starts among the episodes that choose the kept "
                                     "network (default 0: undisturbed episodes only)")
    p.add_argument("--validate-pushes", type=integer("validate pushes", 0), default=0,
                   metavar="N", help="pushed episodes among the episodes that choose the kept "
                                     "network (default 0)")
    p.add_argument("--resume", action="store_true",
                   help="continue from POLICY's learn state (its data set, network, curve)")
    p.add_argument("--json", action="store_true", help="print one JSON object, no progress")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    import json
    import os

    from mjchar.bvh.io.files import check_output
    from mjchar.controllers.core.builder import check_model_file, motion_source
    from mjchar.learn.collect import LearnSetup
    from mjchar.learn.dagger import LearnOptions, learn
    from mjchar.learn.train import LearnError, import_torch
    from mjchar.progress import Progress

    if args.ray_address is not None and args.executor != "ray":
        raise LearnError("--ray-address needs --executor ray")
    source = motion_source(args.clip)
    if not os.path.isfile(source):
        raise LearnError(f"{args.clip}: no such clip (a BVH file or a bundled name: walk, idle)")
    check_model_file(args.model)
    check_output(args.output, inputs=[source, args.model], flag="-o", suffixes=(".npz",))
    import_torch()  # before anything long: the one-line install hint
    if args.rl_share >= 1.0:
        raise LearnError("--rl-share must be below 1: fine-tuning starts from a distilled "
                         "network")
    if args.rl_share > 0:
        from mjchar.learn.finetune import import_sb3

        import_sb3()
    setup = LearnSetup(clip=os.fspath(source) if os.path.isfile(args.clip) else args.clip,
                       loop=args.loop, model=args.model,
                       future_steps=tuple(range(1, args.future_steps + 1)),
                       label_samples=args.label_samples, label_nominal=args.label_nominal)
    opts = LearnOptions(minutes=args.minutes, seed=args.seed, workers=args.workers,
                        executor=args.executor, ray_address=args.ray_address,
                        episodes=args.episodes, episode_seconds=args.episode_seconds,
                        noise=args.noise, rl_share=args.rl_share,
                        perturb_rate=args.perturb_rate, push_rate=args.push_rate,
                        eval_perturbed=args.validate_perturbed,
                        eval_pushes=args.validate_pushes)
    progress = None if args.json else Progress()
    summary = learn(setup, args.output, opts, resume=args.resume, progress=progress,
                    log=progress)
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"wrote {args.output} ({summary.get('iteration', 0)} iterations, "
              f"{summary.get('labels', 0)} labels); curve: {summary['outputs']['curve']}")
    return 0
