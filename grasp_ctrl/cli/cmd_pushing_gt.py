"""``pushing-gt``: pusher force from a tracked planar push (docs/design.md 5.4)."""

from __future__ import annotations

import argparse

NAME = "pushing-gt"
HELP = "planar-pushing ground truth: pusher force from a tracked box trajectory"
DESCRIPTION = (
    "Recover the force the pusher applies to a box from its tracked planar motion (paper section II-C): "
    "Savitzky-Golay velocities/accelerations, Coulomb friction of N particles on the footprint with uniform "
    "pressure, least squares for the force (closed form, or SLSQP as a cross-check). Writes NaN where there "
    "is no contact or the box is not moving."
)
ORDER = 60


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.cli._common_options import hidden_alias

    p.add_argument(
        "--trajectory",
        required=True,
        metavar="PUSH.csv",
        help="columns t, x, y, theta, contact_x, contact_y, in_contact (SI units)",
    )
    boxes = p.add_mutually_exclusive_group(required=True)  # --box-file, or its older name --object
    boxes.add_argument(
        "--box-file",
        metavar="BOX.toml",
        help="the pushed box: mass_kg, size_m = [lx, ly], mu; optional izz_kgm2, gravity",
    )
    # --object names an object of the object file in tune and view; here it was this file
    hidden_alias(boxes, "box_file", "--object", metavar="BOX.toml")
    p.add_argument(
        "--out", required=True, metavar="FORCES.csv", help="output: t, fx_world, fy_world, fx_object, fy_object, moving"
    )
    p.add_argument(
        "--skip-bad-rows",
        action="store_true",
        help="leave out trajectory rows that are short, not numbers or out of range (counted on stderr)",
    )
    p.add_argument("--method", choices=("closed-form", "slsqp"), default="closed-form")
    p.add_argument("--particles", type=int, default=80, help="particles on the footprint (paper: 80)")
    p.add_argument("--k", type=float, default=10.0, help="weight of the linear-acceleration term (paper: 10)")
    p.add_argument("--window-s", type=float, default=0.31, help="Savitzky-Golay window length in seconds")
    p.add_argument(
        "--speed-threshold", type=float, default=0.01, help="m/s; slower samples are static (friction undefined): NaN"
    )


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.files.safe_write import check_output
    from grasp_ctrl.pushing.box import load_box
    from grasp_ctrl.pushing.io import read_push_csv, write_forces_csv
    from grasp_ctrl.pushing.kinematics import planar_motion
    from grasp_ctrl.pushing.solver import pusher_forces

    if args.particles < 1:
        raise UsageError(f"--particles: a positive integer (got {args.particles})")
    if not args.k > 0:
        raise UsageError(f"--k: a positive number (got {args.k})")
    if not args.window_s > 0 or not args.speed_threshold >= 0:
        raise UsageError("--window-s must be > 0 and --speed-threshold >= 0")
    box = load_box(args.box_file)
    check_output(args.out, "--out", formats=("csv",))
    cols = read_push_csv(args.trajectory, skip_bad_rows=args.skip_bad_rows)
    try:
        motion = planar_motion(cols["t"], cols["x"], cols["y"], cols["theta"], window_s=args.window_s)
    except ValueError as exc:
        raise UsageError(f"{args.trajectory}: {exc}") from None
    contact = np.column_stack([cols["contact_x"], cols["contact_y"]])
    forces = pusher_forces(
        motion,
        contact,
        cols["in_contact"] > 0.5,
        box,
        method=args.method,
        n_particles=args.particles,
        k=args.k,
        speed_threshold=args.speed_threshold,
    )
    try:
        write_forces_csv(args.out, forces)
    except OSError as exc:
        raise UsageError(f"{args.out}: cannot write ({exc.strerror or exc})") from None
    n_def = int(np.sum(~np.isnan(forces.f_world[:, 0])))
    print(f"{args.out}: {len(forces.t)} samples, {n_def} with a force estimate, {int(np.sum(~forces.moving))} static")
    return 0
