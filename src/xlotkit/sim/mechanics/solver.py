"""Quasi-static MDEM solve: in-situ initialisation, contact active set, cluster failure.

Sign convention of everything this module returns: **compression positive** (stresses,
pressures, contact normal forces). Internally tension is positive.

Model
-----
Unknowns are the nodal displacements ``u`` measured from the pre-drilling state (the rock
before the hole existed, under the uniform far-field stress ``sigma0`` and pore pressure
``p0``). Per cluster ``c`` (tension positive internally):

* intact: effective contact forces ``F = F0 + K U_n`` with ``F0 = A M^-T s0'`` the forces of
  the initial effective stress ``s0' = -sigma0 + alpha p0 I``; total stress
  ``s = M^T F / A - alpha p I`` (Biot alpha);
* failed / interface: three contacts with normal stiffness ``k_n = K_mm`` (diagonal of the
  intact micro-stiffness, as in the thesis), shear stiffness ``k_s`` and no coupling. With
  ``g = U_n - U_n^0`` the contact is *open* when ``g > 0`` (no force: an open crack carries
  no tension), otherwise ``F_n = k_n g <= 0``; a closed contact sticks with
  ``F_s = k_s (U_s - U_s^0)`` unless ``|F_s| > tan(phi) |F_n|`` when it slips with
  ``F_s = tan(phi) |F_n| sign`` (Coulomb, Eq. 2.22/2.23). The pore/fracture pressure acts
  with coefficient 1 on a failed cluster (fluid on the crack faces).

Equilibrium ``R(u) = f_int(u) - f_ext = 0`` with ``f_ext`` the far-field tractions on the
outer boundary plus the wall pressure on the hole wall. At ``u = 0`` the rock without the
hole is in equilibrium, so the solution is the exact (discrete) response to drilling the
hole and setting the wall pressure: the initial state is *solved*, not "looped into".

The contact conditions make ``R`` piecewise linear; it is solved by a semi-smooth Newton
(primal-dual active set) iteration: each iterate fixes the open/stick/slip status of every
contact, solves the linear system with ``scipy.sparse.linalg.spsolve`` and re-evaluates the
status, until the status no longer changes and the residual is below tolerance.

Failure: after equilibrium, each intact cluster is checked with its cluster-average Terzaghi
effective stress (Eq. 2.15-2.21); overstressed clusters become failed (contact references
set so the contact forces equal those of the cluster's stress at that moment: no jump),
and the step is re-equilibrated, until no more clusters fail.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from xlotkit.errors import InputError
from xlotkit.sim.mechanics import mdem
from xlotkit.sim.mechanics.assembly import (
    assemble_matrix,
    assemble_vector,
    cluster_dofs,
    edge_traction_load,
)
from xlotkit.sim.mechanics.config import (
    BoundaryConditions,
    FracturePlane,
    InSituStress,
    InterfacePlane,
    RockProperties,
    SolverOptions,
)
from xlotkit.sim.mechanics.failure import (
    crack_tip_margin,
    crack_tip_toughness,
    material_length,
    mohr_coulomb_margin,
    strength_fields,
    tensile_margin,
    toughness_margin,
)
from xlotkit.sim.mechanics.fronts import CrackFront, CrackFronts
from xlotkit.sim.mechanics.states import (
    BONDED,
    FAILED_SHEAR,
    FAILED_TENSILE,
    INTACT,
    INTERFACE,
    OPEN,
    PRESET,
    SLIP,
    STICK,
)
from xlotkit.sim.mechanics.wall import WallCriterion
from xlotkit.sim.mesh import BOTTOM, HOLE, LEFT, Mesh

__all__ = [
    "BONDED",
    "CrackFront",
    "FAILED_SHEAR",
    "FAILED_TENSILE",
    "INTACT",
    "INTERFACE",
    "OPEN",
    "PRESET",
    "SLIP",
    "STICK",
    "MechanicsModel",
    "MechanicsResult",
    "MechanicsState",
]

_EPS_OPEN = 1e-9
# active-set iterations before the residual line search is switched on (see _equilibrate)
_LINE_SEARCH_AFTER = 10
# status changes after which a contact counts as chattering (see _equilibrate)
_CHATTER_FLIPS = 3


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.array(a, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class MechanicsState:
    """Mechanical state after an equilibrium solve (read-only arrays, compression positive).

    Attributes
    ----------
    displacement : (n, 2) [m]
        Nodal displacement from the pre-drilling state.
    wall_pressure : float [Pa]
    pore_pressure : (n_c,) [Pa]
        Pressure of each cluster (pore or fracture fluid).
    stress : (n_c, 3) [Pa]
        Cluster total stress ``(sxx, syy, sxy)``, compression positive.
    effective_stress : (n_c, 3) [Pa]
        Terzaghi effective stress ``stress - p I`` used by the failure criteria.
    cluster_state : (n_c,) int
        ``INTACT``, ``FAILED_TENSILE``, ``FAILED_SHEAR``, ``INTERFACE`` or ``PRESET``.
    contact_status : (n_c, 3) int
        ``BONDED`` (intact cluster), ``STICK``, ``SLIP`` or ``OPEN``.
    normal_force, shear_force : (n_c, 3) [N/m]
        Effective contact forces; normal positive in compression.
    gap : (n_c, 3) [m]
        Opening of failed contacts (0 when closed or bonded).
    slip : (n_c, 3) [m]
        Accumulated frictional slip of failed contacts.
    ref_normal, ref_shear : (n_c, 3) [m]
        Stress-free reference relative displacements of failed contacts (internal).
    """

    displacement: np.ndarray
    wall_pressure: float
    pore_pressure: np.ndarray
    stress: np.ndarray
    effective_stress: np.ndarray
    cluster_state: np.ndarray
    contact_status: np.ndarray
    normal_force: np.ndarray
    shear_force: np.ndarray
    gap: np.ndarray
    slip: np.ndarray
    ref_normal: np.ndarray
    ref_shear: np.ndarray

    @property
    def failed(self) -> np.ndarray:
        """Mask of clusters that are not intact (failed, preset or interface)."""
        return self.cluster_state != INTACT

    @property
    def n_failed(self) -> int:
        """Number of failed clusters (tensile, shear or preset; not interfaces)."""
        return int(np.sum((self.cluster_state != INTACT) & (self.cluster_state != INTERFACE)))

    @property
    def n_open(self) -> int:
        """Number of open contacts."""
        return int(np.sum(self.contact_status == OPEN))


@dataclass(frozen=True, eq=False)
class MechanicsResult:
    """Outcome of one quasi-static step.

    Attributes
    ----------
    state : MechanicsState
    converged : bool
    reason : str
        ``"converged"`` or why not.
    iterations : int
        Total active-set (semi-smooth Newton) iterations over all failure rounds.
    failure_rounds : int
        Equilibrium solves separated by new failures.
    new_failures : ndarray of int
        Clusters that failed in this step, in order.
    """

    state: MechanicsState
    converged: bool
    reason: str
    iterations: int
    failure_rounds: int
    new_failures: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))


class MechanicsModel:
    """MDEM model of a mesh: geometry, stiffness, strengths, loads and boundary conditions.

    Parameters
    ----------
    mesh : Mesh
    rock : RockProperties
    stress : InSituStress
        Far field and initial pressures (compression positive).
    boundary : BoundaryConditions, optional
    interfaces : sequence of InterfacePlane, optional
    options : SolverOptions, optional
    fracture_plane : FracturePlane, optional
        Marked clusters that open as a smooth joint once failed.
    permeable_wall : bool
        The well's fluid enters the rock at the hole wall (a coupled model with a
        permeable rock): the wall criterion's pore pressure has the well pressure on the
        wall (:class:`~xlotkit.sim.mechanics.wall.WallCriterion`).

    Notes
    -----
    Everything that depends only on geometry and material (micro-stiffness ``K`` per
    cluster, contact operators, strengths, unit loads) is computed once here.
    """

    def __init__(
        self,
        mesh: Mesh,
        rock: RockProperties,
        stress: InSituStress,
        boundary: BoundaryConditions | None = None,
        interfaces: Sequence[InterfacePlane] = (),
        options: SolverOptions | None = None,
        fracture_plane: FracturePlane | None = None,
        permeable_wall: bool = False,
    ) -> None:
        if not isinstance(mesh, Mesh):
            raise InputError("expected a Mesh", key="mesh")
        self.mesh = mesh
        self.rock = rock
        self.in_situ = stress
        self.boundary = boundary or BoundaryConditions()
        self.options = options or SolverOptions()
        self.interfaces = tuple(interfaces)
        nodes, tris = mesh.nodes, mesh.triangles
        self.n_dof = 2 * mesh.n_nodes
        self.dofs = cluster_dofs(tris)
        g = mdem.cluster_geometry(nodes, tris)
        self.geometry = g
        self.area = g.area
        self.C = mdem.plane_strain_matrix(rock.young, rock.poisson)
        self.M = mdem.m_matrix(g)
        self.K = mdem.micro_stiffness(self.M, self.C, g.area)
        self.bn, self.bs = mdem.contact_operators(g)
        self.k_intact = mdem.intact_cluster_stiffness(self.K, self.bn)
        self.kn = np.einsum("cmm->cm", self.K).copy()
        self.ks = rock.shear_stiffness_ratio * self.kn
        nc = mesh.n_triangles
        self.mu = np.full((nc, 3), math.tan(rock.friction_angle))
        # pressure load vector per cluster: A B^T (1, 1, 0)
        B = mdem.cst_b_matrix(nodes, tris)
        self.g_pressure = g.area[:, None] * (B[:, 0, :] + B[:, 1, :])
        # crack tips and fronts (the crack-tip criterion): the interaction integral's
        # shape-function gradients (c, 2, 3) and compliance, the mesh topology
        self.cracks = CrackFronts(mesh, g.area, np.stack([B[:, 0, 0::2], B[:, 1, 1::2]], axis=1),
                                  np.linalg.inv(self.C), rock.young, rock.poisson)
        # strengths: nominal (smooth field) and size-scaled (at a crack tip); with scaling
        # mode "all" (or scaling off) the two coincide. See strengths() and docs.
        sc = rock.scaling
        self.tensile_strength_tip, self.cohesion_tip = strength_fields(rock, g.area)
        self.tensile_strength, self.cohesion = strength_fields(
            rock, g.area, scaled=sc.enabled and sc.mode == "all")
        self._tip_scaling = sc.enabled and sc.mode == "crack_tip"
        # tensile initiation at the hole wall by the point method at L/2 (one material
        # length with the crack tips' K_IC); None: the wall keeps the cluster average
        length = material_length(rock) if self._tip_scaling else None
        self.wall = (WallCriterion(mesh, length, permeable_wall=permeable_wall)
                     if length is not None and mesh.hole_radius is not None
                     and len(mesh.hole_nodes) else None)
        self.tan_phi = math.tan(rock.friction_angle)
        # contact directions used once a cluster is failed (interfaces override some)
        self.c_normal = g.normal.copy()
        self.c_shear = g.shear.copy()
        self.interface_mask = np.zeros(nc, dtype=bool)
        for plane in self.interfaces:
            self._add_interface(plane)
        # clusters whose contacts follow a fracture plane once failed (their references at
        # failure come from the cluster stress, as for interfaces)
        self.fracture_plane = fracture_plane
        self.joint_mask = np.zeros(nc, dtype=bool)
        if fracture_plane is not None:
            self._add_fracture_plane(fracture_plane)
        self.bn_c = mdem._operators(self.c_normal)
        # shear relative displacement as in DEM: t . (u_j - u_i). (Measuring it against the
        # cluster's CST rotation was tried: inside a cracked cluster that rotation is
        # polluted by the opening and stiffened a pressurised crack; see docs.)
        self.bs_c = mdem._operators(self.c_shear)
        # initial effective (Biot) stress, tension positive, and its contact forces
        s = stress
        sig0 = np.array([s.sigma_x, s.sigma_y, s.sigma_xy])
        self.sigma0 = sig0
        s0_eff = -sig0 + rock.biot * s.pore_pressure * np.array([1.0, 1.0, 0.0])
        Minv = np.linalg.inv(self.M)
        self.F0 = g.area[:, None] * np.einsum("cji,j->ci", Minv, s0_eff)
        self._Minv = Minv
        self._setup_boundary()

    # ------------------------------------------------------------------ setup
    def _add_interface(self, plane: InterfacePlane) -> None:
        p0 = np.array(plane.start)
        p1 = np.array(plane.end)
        d = p1 - p0
        L = float(np.hypot(*d))
        tdir = d / L
        ndir = np.array([-tdir[1], tdir[0]])
        nodes = self.mesh.nodes
        side = (nodes - p0) @ ndir
        along = (nodes - p0) @ tdir
        tri = self.mesh.triangles
        s_t = side[tri]
        a_t = along[tri]
        cut = (s_t.max(axis=1) > 0) & (s_t.min(axis=1) < 0) & (a_t.max(axis=1) > 0) & (
            a_t.min(axis=1) < L)
        ci = np.nonzero(cut)[0]
        self.interface_mask[ci] = True
        mu = math.tan(math.radians(plane.friction_angle_deg))
        for m, (i, j) in enumerate(mdem.CONTACT_NODES):
            si = s_t[ci, i]
            sj = s_t[ci, j]
            crossing = si * sj < 0
            cc = ci[crossing]
            sgn = np.sign(sj[crossing])[:, None]  # normal oriented from node i to node j
            self.c_normal[cc, m] = sgn * ndir
            self.c_shear[cc, m] = sgn * tdir
            self.mu[ci, m] = mu

    def _add_fracture_plane(self, fp: FracturePlane) -> None:
        mesh = self.mesh
        tdir = np.array([math.cos(fp.azimuth), math.sin(fp.azimuth)])
        ndir = np.array([-tdir[1], tdir[0]])
        ci = np.flatnonzero((np.asarray(mesh.triangle_markers) == fp.marker)
                            & ~self.interface_mask)
        self.joint_mask[ci] = True
        # side of each node of the line through the cluster's centroid along the plane
        side = (mesh.nodes[mesh.triangles[ci]] - mesh.centroids[ci, None, :]) @ ndir
        for m, (i, j) in enumerate(mdem.CONTACT_NODES):
            crossing = side[:, i] * side[:, j] < 0
            cc = ci[crossing]
            sgn = np.sign(side[crossing, j])[:, None]  # normal from node i's side to j's
            self.c_normal[cc, m] = sgn * ndir
            self.c_shear[cc, m] = sgn * tdir
        self.mu[ci, :] = math.tan(math.radians(fp.friction_angle_deg))

    def _setup_boundary(self) -> None:
        mesh = self.mesh
        tags = mesh.boundary_tags
        edges = mesh.boundary_edges
        s = self.in_situ
        S0 = -np.array([[s.sigma_x, s.sigma_xy], [s.sigma_xy, s.sigma_y]])
        kind = self.boundary.kind
        fixed = np.zeros(self.n_dof, dtype=bool)
        if kind == "rollers":
            if s.sigma_xy != 0.0:
                raise InputError("rollers cannot carry the far-field shear stress",
                                 key="stress.sigma_xy",
                                 expected="0 with rollers, or boundary.kind='tractions'")
            left = np.unique(edges[tags == LEFT])
            bottom = np.unique(edges[tags == BOTTOM])
            if len(left) == 0 or len(bottom) == 0:
                raise InputError("rollers need a left and a bottom side", key="boundary.kind",
                                 expected="an axis-aligned rectangular outline")
            fixed[2 * left] = True
            fixed[2 * bottom + 1] = True
            traction = (tags != HOLE) & (tags != LEFT) & (tags != BOTTOM)
        else:
            traction = tags != HOLE
            nodes = mesh.nodes
            outer = np.unique(edges[tags != HOLE])
            a = outer[np.argmin(nodes[outer, 0] + nodes[outer, 1])]
            b = outer[np.argmax(nodes[outer, 0] - nodes[outer, 1])]
            fixed[[2 * a, 2 * a + 1, 2 * b + 1]] = True
        self.f_far = edge_traction_load(mesh.nodes, edges[traction], S0)
        self.f_wall = edge_traction_load(mesh.nodes, edges[tags == HOLE], -np.eye(2))
        self.fixed = fixed
        keep = -np.ones(self.n_dof, dtype=np.int64)
        free = ~fixed
        keep[free] = np.arange(int(free.sum()))
        self.keep = keep
        self.free = free

    # ------------------------------------------------------------------ kernels
    def _response(self, u: np.ndarray, cstate: np.ndarray, ref_n: np.ndarray,
                  ref_s: np.ndarray, p: np.ndarray):
        """Contact forces, statuses and cluster internal forces at displacement u."""
        uc = u.reshape(-1)[self.dofs]  # (c, 6)
        failed = cstate != INTACT
        # intact: F = F0 + K U_n (Biot pressure)
        Un_reg = np.einsum("cmi,ci->cm", self.bn, uc)
        F_int = self.F0 + np.einsum("cmn,cn->cm", self.K, Un_reg)
        # failed: contact law
        Un = np.einsum("cmi,ci->cm", self.bn_c, uc)
        Us = np.einsum("cmi,ci->cm", self.bs_c, uc)
        trial_n = self.kn * (Un - ref_n)
        is_open = trial_n > 0.0
        Fn = np.where(is_open, 0.0, trial_n)
        trial_s = self.ks * (Us - ref_s)
        cap = self.mu * (-Fn)
        slip = ~is_open & (np.abs(trial_s) > cap)
        Fs = np.where(is_open, 0.0, np.where(slip, np.sign(trial_s) * cap, trial_s))
        status = np.where(is_open, OPEN, np.where(slip, SLIP, STICK))
        status[~failed] = BONDED
        Fn = np.where(failed[:, None], Fn, F_int)
        Fs = np.where(failed[:, None], Fs, 0.0)
        alpha = np.where(failed, 1.0, self.rock.biot)
        f_c = (np.einsum("cmi,cm->ci", np.where(failed[:, None, None], self.bn_c, self.bn), Fn)
               + np.einsum("cmi,cm->ci", self.bs_c, Fs)
               - (alpha * p)[:, None] * self.g_pressure)
        return Fn, Fs, status, np.sign(trial_s), f_c, Un, Us

    def _tangent_blocks(self, cstate: np.ndarray, status: np.ndarray,
                        sgn: np.ndarray, soft: np.ndarray | None = None) -> np.ndarray:
        """Element tangent blocks; ``soft`` (n_c, 3) marks chattering contacts whose
        shear is linearised with the elastic (stick) stiffness and no normal coupling:
        an initial-stiffness tangent, symmetric and never singular, that converges
        linearly where the exact one cycles."""
        blocks = self.k_intact.copy()
        failed = np.nonzero(cstate != INTACT)[0]
        if len(failed):
            st = status[failed]
            bn = self.bn_c[failed]
            bs = self.bs_c[failed]
            # open contacts keep 1e-9 of their stiffness in the *Jacobian only* (the
            # residual uses the exact zero force): nodes held only by open contacts would
            # otherwise make the matrix singular; the converged answer is unaffected.
            closed = np.where(st != OPEN, 1.0, _EPS_OPEN)
            kn = self.kn[failed] * closed
            kss = self.ks[failed] * np.where(st == STICK, 1.0, _EPS_OPEN)
            kslip = -self.mu[failed] * sgn[failed] * self.kn[failed] * (st == SLIP)
            if soft is not None:
                sf = soft[failed]
                kss = np.where(sf, self.ks[failed], kss)
                kslip = np.where(sf, 0.0, kslip)
            blk = (np.einsum("cm,cmi,cmj->cij", kn, bn, bn)
                   + np.einsum("cm,cmi,cmj->cij", kss, bs, bs)
                   + np.einsum("cm,cmi,cmj->cij", kslip, bs, bn))
            blocks[failed] = blk
        return blocks

    def _equilibrate(self, u, cstate, ref_n, ref_s, p, pw):
        f_ext = self.f_far + pw * self.f_wall
        free = self.free
        prev_status = None
        prev_small = False
        flips = np.zeros(ref_n.shape, dtype=np.int64)
        it = 0
        while True:
            Fn, Fs, status, sgn, f_c, Un, Us = self._response(u, cstate, ref_n, ref_s, p)
            f_int = assemble_vector(f_c, self.dofs, self.n_dof)
            R = (f_int - f_ext)[free]
            scale = np.linalg.norm(assemble_vector(np.abs(f_c), self.dofs, self.n_dof)[free])
            scale = max(scale, np.linalg.norm(f_ext[free]), 1e-300)
            res = np.linalg.norm(R)
            small = res <= self.options.rtol * scale
            # R is evaluated with the exact (non-smooth) contact law, so a small residual is
            # equilibrium; the unchanged-status test only guards against a lucky iterate.
            # Contacts sitting on the open/slip corner (zero normal force) may flip status
            # forever at round-off residuals: two small residuals in a row also converge.
            if small and prev_status is not None and (
                    np.array_equal(status, prev_status) or prev_small):
                return u, (Fn, Fs, status, Un, Us), True, "converged", it
            prev_small = small
            if it >= self.options.max_newton:
                why = ("active set did not settle" if prev_status is not None
                       and not np.array_equal(status, prev_status) else "residual too large")
                return u, (Fn, Fs, status, Un, Us), False, f"{why} after {it} iterations", it
            if prev_status is not None:
                flips += status != prev_status
            # contacts that keep switching between stick/slip/open make the active set
            # cycle; after a few flips their shear is linearised with the stick stiffness
            # (initial-stiffness tangent); with the residual line search below this trades
            # finite termination for robust, linear convergence on those contacts only
            soft = (flips >= _CHATTER_FLIPS) if it >= _LINE_SEARCH_AFTER else None
            blocks = self._tangent_blocks(cstate, status, sgn, soft)
            J = assemble_matrix(blocks, self.dofs, self.n_dof, keep=self.keep)
            diag = J.diagonal()
            floating = diag == 0.0
            if np.any(floating):
                # nodes connected only through open contacts: hold them (no stiffness)
                J = J + _diag(floating.astype(float))
                R = np.where(floating, 0.0, R)
            du = spla.spsolve(J.tocsc(), -R)
            if not np.all(np.isfinite(du)):
                return u, (Fn, Fs, status, Un, Us), False, "singular stiffness", it
            step = 1.0
            if it >= _LINE_SEARCH_AFTER:
                # the full active-set step terminates finitely when the statuses are right,
                # so it is always tried first; contacts at the open/slip corner of the
                # contact law (normal force ~ 0 in a pressurised crack) can make the
                # statuses cycle, then a backtracking line search on |R| restores descent
                step = self._line_search(u, du, res, cstate, ref_n, ref_s, p, f_ext)
            unew = u.reshape(-1).copy()
            unew[free] += step * du
            u = unew.reshape(-1, 2)
            prev_status = status
            it += 1

    def _line_search(self, u, du, res0, cstate, ref_n, ref_s, p, f_ext) -> float:
        """Largest ``2^-k`` (k <= 6) step along ``du`` that lowers ``|R|``; else the
        smallest one tried (a full step that raises the residual can run away)."""
        free = self.free
        step = 1.0
        for _ in range(7):
            trial = u.reshape(-1).copy()
            trial[free] += step * du
            *_, f_c, _, _ = self._response(trial.reshape(-1, 2), cstate, ref_n, ref_s, p)
            r = np.linalg.norm((assemble_vector(f_c, self.dofs, self.n_dof) - f_ext)[free])
            if r < res0:
                return step
            step *= 0.5
        return 2.0 * step

    # ------------------------------------------------------------------ states
    def _make_state(self, u, cstate, ref_n, ref_s, slip, p, pw, resp) -> MechanicsState:
        Fn, Fs, status, Un, Us = resp
        failed = cstate != INTACT
        g = self.geometry
        normal = np.where(failed[:, None, None], self.c_normal, g.normal)
        s_eff = mdem.cluster_stress_from_forces(g.area, g.dx, normal, Fn, self.c_shear, Fs)
        alpha = np.where(failed, 1.0, self.rock.biot)
        iso = np.array([1.0, 1.0, 0.0])
        s_tot = s_eff - (alpha * p)[:, None] * iso
        stress = -s_tot
        eff = stress - p[:, None] * iso
        gap = np.where(failed[:, None], np.maximum(Un - ref_n, 0.0), 0.0)
        return MechanicsState(
            displacement=_ro(u), wall_pressure=float(pw), pore_pressure=_ro(p),
            stress=_ro(stress), effective_stress=_ro(eff), cluster_state=_ro(cstate),
            contact_status=_ro(status), normal_force=_ro(-Fn), shear_force=_ro(Fs),
            gap=_ro(gap), slip=_ro(slip), ref_normal=_ro(ref_n), ref_shear=_ro(ref_s))

    def _pressures(self, pore_pressure, wall_pressure, default_p, default_pw):
        nc = self.mesh.n_triangles
        if pore_pressure is None:
            p = np.array(default_p, dtype=float, copy=True)
        else:
            p = np.broadcast_to(np.asarray(pore_pressure, dtype=float), (nc,)).copy()
        if not np.all(np.isfinite(p)):
            raise InputError("pore pressure must be finite", key="pore_pressure")
        pw = default_pw if wall_pressure is None else float(wall_pressure)
        if not math.isfinite(pw):
            raise InputError("wall pressure must be finite", key="wall_pressure")
        return p, pw

    def initial_state(self, wall_pressure: float | None = None) -> MechanicsState:
        """Equilibrium of the drilled hole in the in-situ stress field.

        The far-field stress, the initial pore pressure and the wall pressure
        (``InSituStress.wall_pressure`` unless given) are applied to the intact rock (with
        the interface clusters in their contact state); no failure is checked here —
        clusters overstressed by drilling fail in the first :meth:`step`.

        Raises
        ------
        RuntimeError
            If the equilibrium solve does not converge.
        """
        nc = self.mesh.n_triangles
        p, pw = self._pressures(None, wall_pressure,
                                np.full(nc, self.in_situ.pore_pressure),
                                self.in_situ.wall_pressure)
        cstate = np.where(self.interface_mask, INTERFACE, INTACT).astype(np.int64)
        u = np.zeros((self.mesh.n_nodes, 2))
        ref_n = np.zeros((nc, 3))
        ref_s = np.zeros((nc, 3))
        if self.interface_mask.any():
            ref_n, ref_s = self._contact_refs(np.nonzero(self.interface_mask)[0], u, p,
                                              ref_n, ref_s, interface=True)
        u, resp, ok, why, _ = self._equilibrate(u, cstate, ref_n, ref_s, p, pw)
        if not ok:
            raise RuntimeError(f"initial equilibrium failed: {why}")
        ref_s, slip = self._commit_slip(resp, ref_s, np.zeros((nc, 3)), cstate)
        return self._make_state(u, cstate, ref_n, ref_s, slip, p, pw, resp)

    def _contact_refs(self, idx, u, p, ref_n, ref_s, interface=False):
        """References of clusters entering a contact state: forces continuous.

        Clusters of the fracture plane (``joint_mask``) are always mapped as interfaces
        (their contact directions are not the sub-edge ones)."""
        idx = np.asarray(idx, dtype=np.int64)
        if not interface and idx.size and self.joint_mask[idx].any():
            j = self.joint_mask[idx]
            ref_n, ref_s = self._contact_refs(idx[j], u, p, ref_n, ref_s, interface=True)
            return self._contact_refs(idx[~j], u, p, ref_n, ref_s)
        ref_n = ref_n.copy()
        ref_s = ref_s.copy()
        uc = u.reshape(-1)[self.dofs[idx]]
        Un_reg = np.einsum("cmi,ci->cm", self.bn[idx], uc)
        F = self.F0[idx] + np.einsum("cmn,cn->cm", self.K[idx], Un_reg)
        # switch from Biot to Terzaghi effective stress: s'_T = s'_B + (1 - alpha) p I
        ds = (1.0 - self.rock.biot) * p[idx]
        F = F + self.area[idx, None] * np.einsum(
            "cji,j->ci", self._Minv[idx], np.array([1.0, 1.0, 0.0])) * ds[:, None]
        if interface:
            # least-norm normal/shear forces along the (modified) contact directions that
            # reproduce the cluster's effective stress
            g = self.geometry
            s_target = np.einsum("cij,cj->ci", np.transpose(self.M[idx], (0, 2, 1)),
                                 F) / self.area[idx, None]
            Fn_new = np.empty((len(idx), 3))
            Fs_new = np.empty((len(idx), 3))
            for k, c in enumerate(idx):
                cols = []
                for m in range(3):
                    for d in (self.c_normal[c, m], self.c_shear[c, m]):
                        f = d
                        dxm = g.dx[c, m]
                        cols.append([f[0] * dxm[0], f[1] * dxm[1],
                                     0.5 * (f[0] * dxm[1] + f[1] * dxm[0])])
                A = np.array(cols).T / self.area[c]
                x, *_ = np.linalg.lstsq(A, s_target[k], rcond=None)
                Fn_new[k] = x[0::2]
                Fs_new[k] = x[1::2]
            F, Fs = Fn_new, Fs_new
        else:
            Fs = np.zeros_like(F)
        Un = np.einsum("cmi,ci->cm", self.bn_c[idx], uc)
        Us = np.einsum("cmi,ci->cm", self.bs_c[idx], uc)
        ref_n[idx] = Un - F / self.kn[idx]
        ref_s[idx] = Us - Fs / self.ks[idx]
        return ref_n, ref_s

    def _commit_slip(self, resp, ref_s, slip, cstate):
        """After a converged step: move shear references by the frictional slip."""
        Fn, Fs, status, Un, Us = resp
        failed = (cstate != INTACT)[:, None]
        new_ref = np.where(status == OPEN, Us, Us - Fs / self.ks)
        new_ref = np.where(failed, new_ref, ref_s)
        dslip = np.where(failed & (status != OPEN), new_ref - ref_s, 0.0)
        return new_ref, slip + np.abs(dslip)

    def fail_clusters(self, state: MechanicsState, clusters: np.ndarray,
                      mode: int = PRESET) -> MechanicsState:
        """Return a copy of ``state`` with ``clusters`` switched to a failed state.

        The contact forces of the switched clusters equal those of their current stress
        (no jump); use :meth:`step` afterwards to re-equilibrate. Used to pre-cut cracks.
        """
        idx = np.unique(np.asarray(clusters, dtype=np.int64))
        if idx.size and (idx.min() < 0 or idx.max() >= self.mesh.n_triangles):
            raise InputError("cluster index out of range", key="clusters")
        cstate = np.array(state.cluster_state)
        idx = idx[cstate[idx] == INTACT]
        ref_n, ref_s = self._contact_refs(idx, np.asarray(state.displacement),
                                          np.asarray(state.pore_pressure),
                                          np.asarray(state.ref_normal),
                                          np.asarray(state.ref_shear))
        cstate[idx] = mode
        p = np.asarray(state.pore_pressure)
        resp = self._response(np.asarray(state.displacement), cstate, ref_n, ref_s, p)
        Fn, Fs, status, _, f_c, Un, Us = resp
        return self._make_state(np.asarray(state.displacement), cstate, ref_n, ref_s,
                                np.asarray(state.slip), p, state.wall_pressure,
                                (Fn, Fs, status, Un, Us))

    # ------------------------------------------------------------------ failure
    def touches_crack(self, cluster_state: np.ndarray) -> np.ndarray:
        """Clusters sharing a node with a failed (tensile, shear or preset) cluster
        (:meth:`CrackFronts.touches_crack`)."""
        return self.cracks.touches_crack(cluster_state)

    def crack_tips(self, state: MechanicsState) -> tuple[np.ndarray, np.ndarray]:
        """Intact clusters ahead of a crack end and the fluid pressure on that crack
        (:meth:`CrackFronts.crack_tips`)."""
        return self.cracks.crack_tips(state)

    def crack_fronts(self, state: MechanicsState) -> list[CrackFront]:
        """The crack fronts with their ``K_I`` and lead cluster
        (:meth:`CrackFronts.fronts`, with the strengths of :meth:`strengths`)."""
        return self.cracks.fronts(state, self.strengths(state.cluster_state)[0])

    @property
    def fracture_toughness(self) -> float | None:
        """Effective mode-I toughness ``K_IC`` [Pa m^0.5] of the crack-tip criterion, or
        None when it has none (scaling off, ``mode="all"`` or exponent != 1/4).

        ``TIP_TOUGHNESS_FACTOR * T * A_ref^(1/4)`` (the given ``StrengthScaling.toughness``
        if set); see :func:`xlotkit.sim.mechanics.failure.crack_tip_toughness`.
        """
        return crack_tip_toughness(self.rock)

    def strengths(self, cluster_state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tensile strength and cohesion [Pa] of every cluster in a given failure state.

        With :class:`StrengthScaling` ``mode="crack_tip"`` an intact cluster that touches a
        failed cluster (:meth:`touches_crack`) has the size-scaled strength
        ``T (A_ref/A)^m`` (it sits in the crack-tip field, where failing it advances the
        crack by ~its size and must release ``G_c``), every other cluster the nominal
        ``T`` (initiation in a smooth field is strength controlled and has no length
        scale). With ``mode="all"`` every cluster is scaled; with scaling off none is.
        """
        if not self._tip_scaling:
            return self.tensile_strength, self.cohesion
        tip = self.touches_crack(cluster_state)
        return (np.where(tip, self.tensile_strength_tip, self.tensile_strength),
                np.where(tip, self.cohesion_tip, self.cohesion))

    def failure_margins(self, state: MechanicsState) -> tuple[np.ndarray, np.ndarray]:
        """Tensile and Mohr-Coulomb margins of every cluster [Pa] (>= 0 means failure).

        The entry point that decides which intact clusters fail. Evaluated on the
        cluster-average Terzaghi effective stress with the strengths of
        :meth:`strengths`, except, with scaling mode ``"crack_tip"``, the tensile
        margin of crack-tip clusters (:meth:`crack_tips`), grouped into crack fronts
        (:meth:`crack_fronts`): a front's lead fails when the mode-I stress intensity of
        the interaction integral reaches the toughness, ``K_I >= K_IC``
        (:attr:`fracture_toughness` times the lead's heterogeneity factor; margin
        :func:`~xlotkit.sim.mechanics.failure.toughness_margin`); the front's other tip
        clusters do not fail in tension (margin ``-T_i``: one cluster per front and failure
        round, the front is re-measured after each). Tip clusters of a group that is not a
        crack end (no lead) keep the cluster-average criterion on the singular part
        (:func:`~xlotkit.sim.mechanics.failure.crack_tip_margin`). With a toughness and
        ``StrengthScaling.wall = "critical_distance"`` the tensile margin of the intact
        near-wall clusters off any crack, and their Mohr-Coulomb margin, are the point
        method's at ``L/2`` from the wall
        (:class:`~xlotkit.sim.mechanics.wall.WallCriterion`). Meaningful for intact
        clusters.
        """
        eff = np.asarray(state.effective_stress)
        cs = np.asarray(state.cluster_state)
        T, S0 = self.strengths(cs)
        mt = tensile_margin(eff, T)
        ms = mohr_coulomb_margin(eff, S0, self.rock.friction_angle)
        if self.wall is not None:
            # near-wall clusters off any crack: the point method at L/2 from the wall
            off = (cs != INTACT) | self.touches_crack(cs)
            wm = self.wall.margins(np.asarray(state.stress), np.asarray(state.pore_pressure),
                                   float(state.wall_pressure), T, S0,
                                   self.rock.friction_angle, off)
            if wm is not None:
                mt[wm[0]], ms[wm[0]] = wm[1], wm[2]
        if self._tip_scaling:
            tip, pf = self.crack_tips(state)
            if tip.any():
                mt[tip] = crack_tip_margin(np.asarray(state.stress)[tip], pf[tip], T[tip])
                fronts = [fr for fr in self.crack_fronts(state) if fr.lead >= 0]
                lead_margin: dict[int, float] = {}
                for fr in fronts:
                    mt[fr.members] = -T[fr.members]
                    m = float(toughness_margin(fr.stress_intensity, self.area[fr.lead],
                                               T[fr.lead]))
                    # two groups may find the same crack end
                    lead_margin[fr.lead] = max(m, lead_margin.get(fr.lead, -math.inf))
                for c, m in lead_margin.items():
                    mt[c] = m
        return mt, ms

    def step(
        self,
        state: MechanicsState,
        wall_pressure: float | None = None,
        pore_pressure: np.ndarray | float | None = None,
        check_failure: bool = True,
    ) -> MechanicsResult:
        """Equilibrate under new pressures, failing clusters until none is overstressed.

        Parameters
        ----------
        state : MechanicsState
            Start (its contact references and shear history are the committed ones).
        wall_pressure : float, optional
            Borehole pressure [Pa]; default unchanged.
        pore_pressure : float or ndarray (n_c,), optional
            Cluster pressures [Pa]; default unchanged.
        check_failure : bool
            Apply the failure criteria (False: contacts only).

        Returns
        -------
        MechanicsResult
        """
        p, pw = self._pressures(pore_pressure, wall_pressure, state.pore_pressure,
                                state.wall_pressure)
        u = np.array(state.displacement)
        cstate = np.array(state.cluster_state)
        ref_n = np.array(state.ref_normal)
        ref_s = np.array(state.ref_shear)
        slip = np.array(state.slip)
        new: list[int] = []
        total_it = 0
        rounds = 0
        opts = self.options
        ok, why = True, "converged"
        while True:
            rounds += 1
            u, resp, ok, why, it = self._equilibrate(u, cstate, ref_n, ref_s, p, pw)
            total_it += it
            if not ok:
                break
            if not check_failure:
                break
            trial = self._make_state(u, cstate, ref_n, ref_s, slip, p, pw, resp)
            mt, ms = self.failure_margins(trial)
            intact = cstate == INTACT
            tens = intact & (mt >= 0.0)
            shear = intact & ~tens & (ms >= 0.0)
            cand = np.nonzero(tens | shear)[0]
            if cand.size == 0:
                break
            if rounds > opts.max_failure_rounds:
                ok, why = False, "too many failure rounds"
                break
            # most overstressed first (margins normalised by the strengths)
            T_c, S_c = self.strengths(cstate)
            sev = np.maximum(mt / np.maximum(T_c, 1.0), ms / np.maximum(S_c, 1.0))[cand]
            cand = cand[np.argsort(-sev, kind="stable")]
            if opts.max_new_failures is not None:
                cand = cand[: int(opts.max_new_failures)]
            ref_n, ref_s = self._contact_refs(cand, u, p, ref_n, ref_s)
            cstate[cand] = np.where(tens[cand], FAILED_TENSILE, FAILED_SHEAR)
            new.extend(int(c) for c in cand)
        if ok:
            ref_s, slip = self._commit_slip(resp, ref_s, slip, cstate)
        st = self._make_state(u, cstate, ref_n, ref_s, slip, p, pw, resp)
        return MechanicsResult(state=st, converged=ok, reason=why, iterations=total_it,
                               failure_rounds=rounds,
                               new_failures=np.array(new, dtype=np.int64))

    # ------------------------------------------------------------------ coupling
    def tangent(self, state: MechanicsState):
        """Reduced tangent stiffness (free DOFs) at ``state``, scipy CSR [N/m^2]."""
        _, _, status, sgn, *_ = self._response(
            np.asarray(state.displacement), np.asarray(state.cluster_state),
            np.asarray(state.ref_normal), np.asarray(state.ref_shear),
            np.asarray(state.pore_pressure))
        blocks = self._tangent_blocks(np.asarray(state.cluster_state), status, sgn)
        return assemble_matrix(blocks, self.dofs, self.n_dof, keep=self.keep)

    def pressure_load(self, state: MechanicsState) -> tuple[np.ndarray, np.ndarray]:
        """Nodal force of a unit pressure in each cluster.

        Returns
        -------
        vectors : ndarray (n_c, 6)
            ``-coef A B^T (1, 1, 0)`` with ``coef = alpha`` (intact) or 1 (failed); the
            internal force changes by ``vectors[c] * dp_c`` on ``dofs[c]``.
        dofs : ndarray (n_c, 6)
        """
        coef = np.where(np.asarray(state.cluster_state) != INTACT, 1.0, self.rock.biot)
        return -coef[:, None] * self.g_pressure, self.dofs


def _diag(v: np.ndarray):
    return sp.diags(v, format="csr")


