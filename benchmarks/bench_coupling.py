"""Benchmark: monolithic coupled fracture growth from the borehole (run on demand).

    .venv/bin/python benchmarks/bench_coupling.py [--length 10] [--size 100] [--wall 64]
                                                  [--toughness 1.0]

Thesis 4.2 case (sigma_H = 35 MPa along x, sigma_h = 30 MPa, p0 = 20 MPa, k = 1e-19 m^2,
brine, segment height 10 m, the segment's hole volume as well storage), default borehole
mesh (``borehole_mesh()``: 100 m square, 64 wall segments), constant injection rate until
the fracture is ``--length`` metres long tip to tip. Prints a Markdown table: wall time,
steps (accepted / cut), Newton iterations, linear solves, failed clusters, share of the
wall time in the sparse LU (factorisation + solve) and the largest relative mass-balance
error; the numbers in docs/benchmarks.md were made with it (``--toughness 1.0``:
crack-tip strength scaling with K_IC = 1 MPa m^0.5, and without it).
"""

from __future__ import annotations

import argparse
import math
import time


def main() -> None:
    from xlotkit.sim.coupling import (
        CoupledModel,
        CoupledStepper,
        TimeStepControl,
        fracture_summary,
    )
    from xlotkit.sim.flow import (
        FlowModel,
        FluidProperties,
        OuterBoundary,
        RockFlowProperties,
        WellCondition,
    )
    from xlotkit.sim.mechanics import (
        InSituStress,
        MechanicsModel,
        RockProperties,
        StrengthScaling,
    )
    from xlotkit.sim.mesh import borehole_mesh

    ap = argparse.ArgumentParser()
    ap.add_argument("--length", type=float, default=10.0, help="tip-to-tip length [m]")
    ap.add_argument("--size", type=float, default=100.0, help="domain size [m]")
    ap.add_argument("--wall", type=int, default=64, help="wall segments")
    ap.add_argument("--rate", type=float, default=2e-4, help="injection [m^3/s] per segment")
    ap.add_argument("--t-max", type=float, default=20000.0, help="give up after [s]")
    ap.add_argument("--toughness", type=float, default=None,
                    help="crack-tip strength scaling with this K_IC [MPa m^0.5] "
                         "(default: none, the thesis's unscaled T0 = 5 MPa)")
    args = ap.parse_args()

    a = 0.15
    mesh = borehole_mesh(size=args.size, radius=a, h_wall=2 * math.pi * a / args.wall)
    scaling = (StrengthScaling() if args.toughness is None else
               StrengthScaling(enabled=True, toughness=args.toughness * 1e6))
    mech = MechanicsModel(mesh, RockProperties(young=10e9, poisson=0.25, biot=1.0,
                                               tensile_strength=5e6, scaling=scaling),
                          InSituStress(35e6, 30e6, 0.0, 20e6))
    flow = FlowModel(mesh, FluidProperties(compressibility=4.5e-10, viscosity=1e-3,
                                           reference_pressure=20e6),
                     RockFlowProperties(1e-19, 0.1, 0.0, 20e6), WellCondition(rate=args.rate),
                     OuterBoundary.fixed_pressure(20e6), height=10.0)
    model = CoupledModel(mech, flow, residual_aperture=1e-5)
    print(f"mesh: {mesh.n_triangles} triangles, {model.n_unknowns} unknowns; crack-tip "
          f"toughness {args.toughness} MPa m^0.5", flush=True)
    t0 = time.perf_counter()
    stp = CoupledStepper(model)
    marks = {"next": 1.0}

    def progress(r, s):
        # one line per metre of growth, so a run cut short still leaves its numbers
        fs = fracture_summary(model, s)
        if fs.length >= marks["next"]:
            c = stp.counters
            el = time.perf_counter() - t0
            print(f"progress: L = {fs.length:.2f} m at t = {s.t:.2f} s, wall {el:.0f} s, "
                  f"steps {c.steps}/{c.failed_steps} cut, Newton {c.newton_iterations}, "
                  f"solves {c.linear_solves}, LU {100 * c.linear_solve_time / el:.0f} %, "
                  f"failed {fs.n_failed}, p_w {s.p_w / 1e6:.3f} MPa", flush=True)
            while marks["next"] <= fs.length:
                marks["next"] += 1.0

    res = stp.run(args.t_max, TimeStepControl(dt_initial=2.0, dt_min=1e-4, dt_max=5.0),
                  stop=lambda s: fracture_summary(model, s).length >= args.length,
                  callback=progress)
    wall = time.perf_counter() - t0
    c = stp.counters
    fs = fracture_summary(model, stp.state)
    print(f"mesh: {mesh.n_triangles} triangles, {model.n_unknowns} unknowns; "
          f"run status {res.status}: {res.message}")
    print("| quantity | value |")
    print("|---|---:|")
    print(f"| simulated time [s] | {stp.state.t:.2f} |")
    print(f"| fracture length tip to tip [m] (wings {fs.wing_lengths[0]:.2f} / "
          f"{fs.wing_lengths[1]:.2f}) | {fs.length:.2f} |")
    print(f"| failed clusters | {fs.n_failed} |")
    print(f"| wall time [s] | {wall:.1f} |")
    print(f"| accepted / cut steps | {c.steps} / {c.failed_steps} |")
    print(f"| smallest accepted step [s] | {res.min_dt:.2e} |")
    print(f"| Newton iterations | {c.newton_iterations} |")
    print(f"| linear solves | {c.linear_solves} |")
    print(f"| failure rounds (re-solves) | {c.failure_rounds} |")
    print(f"| time in sparse LU [s] (share) | {c.linear_solve_time:.1f} "
          f"({100 * c.linear_solve_time / wall:.0f} %) |")
    print(f"| max relative mass-balance error | {res.max_relative_mass_balance_error:.1e} |")


if __name__ == "__main__":
    main()
