"""``mjchar convert INPUT.bvh -o OUTPUT.xml``: build a simulated humanoid from a BVH skeleton."""

from __future__ import annotations

import argparse

from . import command_parser
from .dropped import dropped_lines


def register(sub: argparse._SubParsersAction) -> None:
    p = command_parser(
        sub, "convert",
        description="Convert a BVH skeleton into a MuJoCo humanoid (MJCF). Units and the up axis "
                    "are detected unless given; fingers and end markers are dropped and "
                    "zero-length helper joints fused by default (see docs/converter.md).")
    p.add_argument("input", help="BVH file")
    p.add_argument("-o", "--output", help="MJCF file to write (default: INPUT with .xml)")
    p.add_argument("--mass", type=float, default=70.0, help="total mass in kg (default 70)")
    p.add_argument("--joint-model", default="hinge", metavar="{hinge,full,ball}",
                   help="hinge: hinge triplets, one hinge for knees/elbows, anatomical ranges "
                        "(default); full: hinge triplets everywhere, no ranges, exact replay; "
                        "ball: ball joints with motors")
    p.add_argument("--unit", help="file unit: m, dm, cm, mm, in, ft, cmu (the CMU ASF unit, 1/0.45 "
                                  "inch) or metres per unit (default: guessed from the body's "
                                  "size)")
    p.add_argument("--up", choices=["x", "y", "z", "-x", "-y", "-z"],
                   help="up axis of the file, -y when +Y points down (default: guessed)")
    p.add_argument("--drop", help="comma-separated joints to remove with their subtrees; "
                                  "'default' adds the defaults, 'none' drops nothing")
    p.add_argument("--fuse", help="comma-separated joints to merge into their parent body; "
                                  "'default' adds the defaults, 'none' fuses nothing")
    p.add_argument("--gains", metavar="FILE.json",
                   help="gains overrides: {joint name | role | base role | default: "
                        "{kp, kd, torque, armature, damping}}")
    p.add_argument("--roles", metavar="FILE.toml",
                   help="role map for joints the names and shape do not tell: TOML lines like "
                        "left_knee = \"Bip01_L_Calf\" (top level or under [roles]; spine and "
                        "neck take lists); see docs/converter.md")
    p.add_argument("--verify", action="store_true",
                   help="replay the file's motion in the model and report joint and "
                        "end-effector position errors (mm)")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object (errors with --verify, mass, sizes, dropped)")
    p.set_defaults(func=main)


def _split(value: str | None) -> list[str] | None:
    if value is None:
        return None
    return [v.strip() for v in value.split(",") if v.strip()]


def main(args: argparse.Namespace) -> int:
    import json
    import os

    from mjchar.bvh.io.files import check_output
    from mjchar.bvh.mjcf import convert

    output = args.output or os.path.splitext(args.input)[0] + ".xml"
    check_output(output, inputs=[args.input, args.gains, args.roles],
                 flag="-o" if args.output else "the output (INPUT with .xml)")
    converted = convert(
        args.input, total_mass=args.mass, joint_model=args.joint_model, unit=args.unit,
        up_axis=args.up, drop=_split(args.drop), fuse=_split(args.fuse), gains=args.gains,
        roles=args.roles)
    model = converted.compile()
    converted.save(output)
    s = converted.summary
    if s["height_warning"]:
        import sys

        print(f"warning: {s['height_warning']}", file=sys.stderr)
    errors = None
    if args.verify:
        from mjchar.bvh.reference.reference_motion import replay_errors
        from mjchar.progress import Progress

        bar = Progress(enabled=False if args.json else None)
        try:
            errors = replay_errors(model, converted.motion,
                                   progress=bar.counter("verify", "frames"))
        finally:
            bar.close()
    if args.json:
        out = {
            "output": output,
            "worst_error_mm": errors["max_mm"] if errors else None,
            "worst_end_effector_error_mm": errors["end_effector_max_mm"] if errors else None,
            "total_mass_kg": round(float(model.body_mass.sum()), 6),
            "n_bodies": int(model.nbody - 1),
            "n_dofs": int(model.nv),
            "n_actuators": int(model.nu),
            "joint_model": args.joint_model,
            "unit": s["unit_name"],
            "unit_scale": s["unit_scale"],
            "height_m": round(float(s["height_m"]), 6),
            "dropped_joints": converted.info.dropped,
            "fused_joints": s["fused"],
            "warnings": converted.warnings,
        }
        if errors:
            out["joint_errors_mm"] = errors["joints_mm"]
            out["end_effector_errors_mm"] = errors["end_effectors_mm"]
        print(json.dumps(out))
        return 0
    info = converted.info
    print(f"{args.input} -> {output}")
    print(f"  {s['n_bodies']} bodies, {model.nv} dofs ({model.nv - 6} joint dofs + free root), "
          f"{model.nu} actuators, joint model {args.joint_model}")
    print(f"  total mass {model.body_mass.sum():.3f} kg, up axis {info.up_axis}")
    print(f"  unit: {s['unit']}; height {s['height_m']:.3f} m")
    for line in dropped_lines(converted):
        print(f"  {line}")
    for w in converted.warnings:
        if w != s["height_warning"]:  # that one went to stderr
            print(f"  warning: {w}")
    if errors:
        print(f"  replay ({errors['n_frames']} frames): worst joint error "
              f"{errors['max_mm']:.3f} mm ({errors['max_joint']}), worst end-effector error "
              f"{errors['end_effector_max_mm']:.3f} mm ({errors['end_effector']})")
        for name, err in errors["joints_mm"].items():
            print(f"    {name:24s} {err:9.3f} mm")
    return 0
