"""Benchmark: assemble + solve the elastic MDEM borehole problem on growing meshes.

Run ``python benchmarks/bench_mechanics.py`` (not part of the test suite). Prints, for
meshes of about 5k, 20k and 80k triangles, the seconds spent in model setup (geometry,
micro-stiffness K per cluster), in one equilibrium solve (assembly of the sparse stiffness
plus ``spsolve``) and the fitted growth exponent ``t ~ n^k`` of the solve.
"""

from __future__ import annotations

import math
import time

import numpy as np

from xlotkit.sim.mechanics import InSituStress, MechanicsModel, RockProperties
from xlotkit.sim.mesh import borehole_mesh, refine_uniform


def main() -> None:
    base = borehole_mesh(h_wall=2 * math.pi * 0.15 / 64, growth=1.125)
    meshes = [base, refine_uniform(base), refine_uniform(refine_uniform(base))]
    rows = []
    for mesh in meshes:
        t0 = time.perf_counter()
        model = MechanicsModel(mesh, RockProperties(), InSituStress())
        t1 = time.perf_counter()
        best = math.inf
        for _ in range(3):
            ta = time.perf_counter()
            model.initial_state()
            best = min(best, time.perf_counter() - ta)
        rows.append((mesh.n_triangles, 2 * mesh.n_nodes, t1 - t0, best))
        print(f"{mesh.n_triangles:8d} triangles {2 * mesh.n_nodes:8d} dof  "
              f"setup {t1 - t0:7.3f} s  assemble+solve {best:7.3f} s", flush=True)
    n = np.array([r[0] for r in rows], float)
    t = np.array([r[3] for r in rows])
    k = np.polyfit(np.log(n), np.log(t), 1)[0]
    print(f"growth exponent of assemble+solve: t ~ n^{k:.2f}")


if __name__ == "__main__":
    main()
