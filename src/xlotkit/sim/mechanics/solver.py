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
from xlotkit.sim.mechanics.closure import ClosureLaw, closure_of_stress, stress_of_closure
from xlotkit.sim.mechanics.config import (
    BoundaryConditions,
    CrackPlanes,
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
from xlotkit.sim.mechanics.kernels import contact_response, tangent_blocks
from xlotkit.sim.mechanics.planes import (
    choose_conjugate,
    joint_lengths,
    joint_operators,
    mean_axis,
    operator_stress,
    plane_crossing,
    plane_tangent,
    shear_plane_normals,
    tensile_plane_normal,
)
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
    crack_normal : (n_c, 2)
        Unit normal of each failed cluster's crack plane, set when it failed
        (:class:`~xlotkit.sim.mechanics.config.CrackPlanes`; the preset direction for a
        :class:`FracturePlane` cluster); zeros where there is none (intact, interface,
        or failed without crack planes).
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
    crack_normal: np.ndarray

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
    crack_planes : CrackPlanes, optional
        Every other cluster gets its own crack plane when it fails (the free path; see
        :class:`CrackPlanes`). Default None: failed clusters keep their sub-edge contacts.
    closure : ClosureLaw, optional
        Normal law of closed crack contacts (:mod:`xlotkit.sim.mechanics.closure`);
        default the smooth law (the contact's linear stiffness ``k_n``). A closure law acts
        on the contacts that cross a crack plane (of :class:`CrackPlanes`, a
        :class:`FracturePlane` or an :class:`InterfacePlane`), or on all three contacts of
        a failed cluster without a plane; with the joint length ``l_m``
        (:func:`~xlotkit.sim.mechanics.planes.joint_lengths`) a closed contact carries
        ``F_n = -l_m sigma(delta)``.
    permeable_wall : bool
        The well's fluid enters the rock at the hole wall (a coupled model with a
        permeable rock): the wall criterion's pore pressure has the well pressure on the
        wall (:meth:`~xlotkit.sim.mechanics.wall.WallCriterion.point_pore_pressure`).

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
        crack_planes: CrackPlanes | None = None,
        closure: ClosureLaw | None = None,
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
        # (the leak-off profile fit of WallCriterion(far_pressure=p0) is not enabled: with
        # it the tight hard cases of tests/stability, L/2 = 2 mm, start at 30 MPa above the
        # penetrating initiation and fail at once and off axis; docs/mechanics.md)
        self.wall = (WallCriterion(mesh, length, permeable_wall=permeable_wall)
                     if length is not None and mesh.hole_radius is not None
                     and len(mesh.hole_nodes) else None)
        self.tan_phi = math.tan(rock.friction_angle)
        # contact directions used once a cluster is failed (interfaces override some)
        self.c_normal = g.normal.copy()
        self.c_shear = g.shear.copy()
        # contacts on a crack plane (where a closure law acts) and their joint lengths
        self.joint = np.zeros((nc, 3), dtype=bool)
        self.interface_mask = np.zeros(nc, dtype=bool)
        for plane in self.interfaces:
            self._add_interface(plane)
        # clusters whose contacts follow a fracture plane once failed (their references at
        # failure come from the cluster stress, as for interfaces)
        self.fracture_plane = fracture_plane
        self.joint_mask = np.zeros(nc, dtype=bool)
        self._preset_normal = np.zeros(2)
        if fracture_plane is not None:
            self._add_fracture_plane(fracture_plane)
        if crack_planes is not None and not isinstance(crack_planes, CrackPlanes):
            raise InputError("expected CrackPlanes or None", key="crack_planes")
        self.closure = ClosureLaw() if closure is None else closure
        if not isinstance(self.closure, ClosureLaw):
            raise InputError("expected a ClosureLaw", key="closure")
        # clusters that get their own crack plane when they fail (the free path)
        self.crack_planes = crack_planes
        self.plane_free = ((~self.interface_mask & ~self.joint_mask) if crack_planes is not None
                           else np.zeros(nc, dtype=bool))
        if crack_planes is not None:
            self.mu[self.plane_free, :] = math.tan(math.radians(crack_planes.friction_angle_deg))
        else:
            # no planes: a failed cluster's crack is in all three of its contacts
            self.joint[~self.interface_mask & ~self.joint_mask] = True
        # normals the contact rows of plane_free clusters were last built with (sync_planes)
        self._plane_applied = np.zeros((nc, 2))
        self._touch: sp.csr_matrix | None = None
        self.bn_c = mdem._operators(self.c_normal)
        # shear relative displacement as in DEM: t . (u_j - u_i). (Measuring it against the
        # cluster's CST rotation was tried: inside a cracked cluster that rotation is
        # polluted by the opening and stiffened a pressurised crack; see docs.)
        self.bs_c = mdem._operators(self.c_shear)
        self.ell = joint_lengths(g.area, g.dx, self.c_normal, self.joint)
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
            self.joint[cc, m] = True
            self.mu[ci, m] = mu

    def _add_fracture_plane(self, fp: FracturePlane) -> None:
        mesh = self.mesh
        tdir = np.array([math.cos(fp.azimuth), math.sin(fp.azimuth)])
        ndir = np.array([-tdir[1], tdir[0]])
        ci = np.flatnonzero((np.asarray(mesh.triangle_markers) == fp.marker)
                            & ~self.interface_mask)
        self.joint_mask[ci] = True
        self._preset_normal = ndir
        # side of each node of the line through the cluster's centroid along the plane
        side = (mesh.nodes[mesh.triangles[ci]] - mesh.centroids[ci, None, :]) @ ndir
        for m, (i, j) in enumerate(mdem.CONTACT_NODES):
            crossing = side[:, i] * side[:, j] < 0
            cc = ci[crossing]
            sgn = np.sign(side[crossing, j])[:, None]  # normal from node i's side to j's
            self.c_normal[cc, m] = sgn * ndir
            self.c_shear[cc, m] = sgn * tdir
            self.joint[cc, m] = True
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

    # ------------------------------------------------------------------ crack planes
    def set_crack_planes(self, clusters: np.ndarray, tensile: np.ndarray,
                         effective_stress: np.ndarray, cluster_state: np.ndarray,
                         crack_normal: np.ndarray,
                         plane_normal: np.ndarray | None = None) -> np.ndarray:
        """Crack planes of clusters about to fail, applied to their contacts.

        Call before the clusters' contact references are set (:meth:`_contact_refs`) and
        before ``cluster_state`` marks them failed.

        Parameters
        ----------
        clusters : ndarray of int (k,)
            The clusters that fail now.
        tensile : ndarray of bool (k,)
            Tensile (True) or shear failure of each.
        effective_stress : ndarray (n_c, 3)
            Terzaghi effective stress at failure [Pa], compression positive.
        cluster_state : ndarray of int (n_c,)
            States before these failures (which neighbours are cracked already).
        crack_normal : ndarray (n_c, 2)
            Crack planes so far.
        plane_normal : ndarray (2,) or (k, 2), optional
            Planes to use instead of the stress's (pre-cut cracks).

        Returns
        -------
        ndarray (n_c, 2)
            ``crack_normal`` with the new clusters' planes: from the stress
            (:mod:`~xlotkit.sim.mechanics.planes`) for clusters of :attr:`plane_free`,
            the preset direction for :class:`FracturePlane` clusters, zeros otherwise.
        """
        idx = np.asarray(clusters, dtype=np.int64)
        out = np.array(crack_normal, dtype=float, copy=True)
        if idx.size == 0:
            return out
        out[idx[self.joint_mask[idx]]] = self._preset_normal
        free = self.plane_free[idx]
        if not free.any():
            return out
        cf = idx[free]
        if plane_normal is not None:
            pn = np.broadcast_to(np.asarray(plane_normal, dtype=float), (len(idx), 2))[free]
            nrm = pn / np.linalg.norm(pn, axis=1, keepdims=True)
        else:
            eff = np.asarray(effective_stress, dtype=float)[cf]
            nrm = tensile_plane_normal(eff)
            ten = np.asarray(tensile, dtype=bool)[free]
            for k, c in enumerate(cf):
                if ten[k]:
                    # at a crack (it shares a node with cracked clusters): the crack's
                    # line, the mean plane of those clusters (planes module docstring)
                    ax = self._nearby_axis(int(c), cluster_state, out, mode_one=True)
                    if np.any(ax != 0.0):
                        nrm[k] = ax
            sh = ~ten
            if sh.any():
                cand = shear_plane_normals(eff[sh], self.rock.friction_angle)
                ref = np.array([self._nearby_axis(int(c), cluster_state, out)
                                for c in cf[sh]]).reshape(-1, 2)
                nrm[sh] = choose_conjugate(cand, ref)
        out[cf] = nrm
        self._apply_planes(cf, nrm, ~np.asarray(tensile, dtype=bool)[free])
        return out

    def _nearby_axis(self, c: int, cluster_state: np.ndarray, crack_normal: np.ndarray,
                     mode_one: bool = False) -> np.ndarray:
        """Mean plane normal of the cracked clusters sharing a node with ``c`` (zeros:
        none): the crack line a tensile failure continues (``mode_one``: of the clusters
        failed in tension or preset only; a shear crack beside a mode-I crack is not its
        line, and its plane, ~60 deg off, turned the line of the standard scene's crack
        by up to 33 deg), the reference of a shear failure's conjugate plane (all)."""
        if self._touch is None:
            inc = self.cracks.incidence
            self._touch = (inc @ inc.T).tocsr()
        row = self._touch.indices[self._touch.indptr[c]:self._touch.indptr[c + 1]]
        cs = np.asarray(cluster_state)[row]
        nb = row[((cs == FAILED_TENSILE) | (cs == PRESET)) if mode_one
                 else ((cs != INTACT) & (cs != INTERFACE))]
        n = np.asarray(crack_normal)[nb]
        n = n[np.any(n != 0.0, axis=1)]
        return mean_axis(n) if len(n) else np.zeros(2)

    def _apply_planes(self, idx: np.ndarray, normals: np.ndarray, shear: np.ndarray) -> None:
        """Contact directions, operators, joint lengths and friction of clusters ``idx``
        on the planes ``normals`` (unit, (k, 2)); crossing contacts as in
        :class:`FracturePlane`. Clusters failed in tension (``shear`` False) slide with
        the crack faces' friction (:class:`CrackPlanes`), in shear with the rock's: a
        Mohr-Coulomb plane is a plane of friction ``phi`` (a frictionless one, free to
        slide, unloads its neighbours and fails them in turn)."""
        g = self.geometry
        tris = self.mesh.triangles[idx]
        pts = self.mesh.nodes[tris]
        cross, sgn = plane_crossing(pts, pts.mean(axis=1), normals)
        nd = sgn[..., None] * normals[:, None, :]
        td = sgn[..., None] * plane_tangent(normals)[:, None, :]
        cn = np.where(cross[..., None], nd, g.normal[idx])
        ct = np.where(cross[..., None], td, g.shear[idx])
        self.c_normal[idx] = cn
        self.c_shear[idx] = ct
        self.bn_c[idx], self.bs_c[idx] = joint_operators(g.dx[idx], cn, ct, cross)
        self.joint[idx] = cross
        self.ell[idx] = joint_lengths(g.area[idx], g.dx[idx], cn, cross)
        self.mu[idx, :] = np.where(np.asarray(shear, dtype=bool), self.tan_phi,
                                   math.tan(math.radians(self.crack_planes.friction_angle_deg))
                                   )[:, None]
        self._plane_applied[idx] = normals

    def sync_planes(self, cluster_state: np.ndarray, crack_normal: np.ndarray) -> None:
        """Make the contact rows of failed clusters follow the crack planes of a state.

        The contact directions of a :attr:`plane_free` cluster are built when it fails
        (:meth:`set_crack_planes`); a state from elsewhere (a checkpoint, a rejected step
        retried) may carry other planes. Rebuilds the rows whose plane differs (cheap
        when none does). Intact clusters' rows are never read.
        """
        if self.crack_planes is None:
            return
        cn = np.asarray(crack_normal, dtype=float)
        fl = (np.asarray(cluster_state) != INTACT) & self.plane_free
        diff = fl & np.any(cn != self._plane_applied, axis=1) & np.any(cn != 0.0, axis=1)
        if diff.any():
            idx = np.flatnonzero(diff)
            self._apply_planes(idx, cn[idx], np.asarray(cluster_state)[idx] == FAILED_SHEAR)

    def plane_azimuth(self, crack_normal: np.ndarray) -> np.ndarray:
        """Direction of each crack plane [deg] in [0, 180) from +x; nan without one."""
        cn = np.asarray(crack_normal, dtype=float)
        t = plane_tangent(cn)
        az = np.degrees(np.arctan2(t[:, 1], t[:, 0])) % 180.0
        return np.where(np.any(cn != 0.0, axis=1), az, np.nan)

    # ------------------------------------------------------------------ contact law
    def normal_force(self, gap: np.ndarray) -> np.ndarray:
        """Trial normal force [N/m] of every contact at the gap ``g = U_n - U_n^0`` [m]
        (tension positive; used where ``g <= 0``, its sign alone where ``g > 0``).

        Smooth law: ``k_n g``. With a closure law, joint contacts
        (:attr:`joint`) carry ``-l_m sigma(-g)`` (``sigma`` of
        :func:`~xlotkit.sim.mechanics.closure.stress_of_closure`, its initial tangent
        line for ``g > 0``), the other contacts ``k_n g``.
        """
        f = self.kn * gap
        if self.closure.nonlinear:
            j = self.joint
            sig, _ = stress_of_closure(self.closure, -gap[j])
            f[j] = -self.ell[j] * sig
        return f

    def normal_stiffness(self, gap: np.ndarray) -> np.ndarray:
        """Tangent ``d F_n / d g`` [N/m] of :meth:`normal_force` (``k_n`` itself, the same
        array, for the smooth law)."""
        if not self.closure.nonlinear:
            return self.kn
        k = self.kn.copy()
        j = self.joint
        _, kt = stress_of_closure(self.closure, -gap[j])
        k[j] = self.ell[j] * kt
        return k

    def _gap_of_force(self, F: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """Gap at which the contacts of clusters ``idx`` carry the normal forces ``F``
        (inverse of :meth:`normal_force`; tension opens by ``F / k_0``)."""
        gap = F / self.kn[idx]
        if self.closure.nonlinear:
            j = self.joint[idx]
            ell = self.ell[idx][j]
            fj = F[j]
            comp = fj < 0.0
            k0 = ell * self.closure.initial_stiffness
            gj = fj / k0
            gj[comp] = -closure_of_stress(self.closure, -fj[comp] / ell[comp])
            gap[j] = gj
        return gap

    # ------------------------------------------------------------------ kernels
    def _response(self, u: np.ndarray, cstate: np.ndarray, ref_n: np.ndarray,
                  ref_s: np.ndarray, p: np.ndarray, frozen=None):
        """Contact forces, statuses and cluster internal forces at u
        (:func:`~xlotkit.sim.mechanics.kernels.contact_response` with this model's contact
        operators, stiffnesses and friction; ``frozen`` holds contacts on a branch).

        With a closure law the kernel gets each contact's secant normal stiffness
        ``F_n(g) / g`` (:meth:`normal_force`): the same trial force, sign and friction cap
        as the law's, so statuses and forces are the law's while the kernel stays one
        linear form. Returns ``(Fn, Fs, status, sgn, f_c, Un, Us)``."""
        kn = self._secant_normal(u, ref_n) if self.closure.nonlinear else self.kn
        return contact_response(u, self.dofs, cstate, ref_n, ref_s, p, bn=self.bn, K=self.K,
                                F0=self.F0, bn_c=self.bn_c, bs_c=self.bs_c, kn=kn,
                                ks=self.ks, mu=self.mu, g_pressure=self.g_pressure,
                                biot=self.rock.biot, frozen=frozen)

    def _secant_normal(self, u: np.ndarray, ref_n: np.ndarray) -> np.ndarray:
        """Secant normal stiffness ``F_n(g) / g`` [N/m] of every contact at u (the tangent
        where ``g = 0``), for the kernel's linear form of a nonlinear closure law."""
        uc = np.asarray(u).reshape(-1)[self.dofs]
        gap = np.einsum("cmi,ci->cm", self.bn_c, uc) - ref_n
        f = self.normal_force(gap)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(gap != 0.0, f / gap, self.normal_stiffness(gap))

    def _tangent_blocks(self, cstate: np.ndarray, status: np.ndarray,
                        sgn: np.ndarray, soft: np.ndarray | None = None,
                        kn: np.ndarray | None = None) -> np.ndarray:
        """Element tangent blocks (:func:`~xlotkit.sim.mechanics.kernels.tangent_blocks`);
        ``soft`` (n_c, 3) marks chattering contacts whose shear is linearised with the
        elastic (stick) stiffness and no normal coupling: an initial-stiffness tangent,
        symmetric and never singular, that converges linearly where the exact one cycles.
        ``kn`` (n_c, 3): the contacts' tangent normal stiffness (:meth:`normal_stiffness`;
        default ``k_n``, the smooth law). Open contacts keep ``EPS_OPEN`` of their
        stiffness in the *Jacobian only* (the residual uses the exact zero force): nodes
        held only by open contacts would otherwise make the matrix singular; the converged
        answer is unaffected."""
        return tangent_blocks(cstate, status, sgn, k_intact=self.k_intact, bn_c=self.bn_c,
                              bs_c=self.bs_c, kn=self.kn if kn is None else kn, ks=self.ks,
                              mu=self.mu, soft=soft)

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
            blocks = self._tangent_blocks(cstate, status, sgn, soft,
                                          self.normal_stiffness(Un - ref_n))
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
    def _make_state(self, u, cstate, ref_n, ref_s, slip, p, pw, resp,
                    crack_normal) -> MechanicsState:
        Fn, Fs, status, Un, Us = resp
        failed = cstate != INTACT
        g = self.geometry
        normal = np.where(failed[:, None, None], self.c_normal, g.normal)
        s_eff = mdem.cluster_stress_from_forces(g.area, g.dx, normal, Fn, self.c_shear, Fs)
        pf = np.flatnonzero(failed & self.plane_free)
        if pf.size:
            # clusters on their own planes: the virtual-work stress of their operators
            # (which carry the face couple, planes.joint_operators)
            pts = self.mesh.nodes[self.mesh.triangles[pf]]
            s_eff[pf] = (np.einsum("cm,cmk->ck", Fn[pf],
                                   operator_stress(self.bn_c[pf], pts, g.area[pf]))
                         + np.einsum("cm,cmk->ck", Fs[pf],
                                     operator_stress(self.bs_c[pf], pts, g.area[pf])))
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
            gap=_ro(gap), slip=_ro(slip), ref_normal=_ro(ref_n), ref_shear=_ro(ref_s),
            crack_normal=_ro(crack_normal))

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
        return self._make_state(u, cstate, ref_n, ref_s, slip, p, pw, resp, np.zeros((nc, 2)))

    def _contact_refs(self, idx, u, p, ref_n, ref_s, interface=False):
        """References of clusters entering a contact state: forces continuous.

        Clusters of the fracture plane (``joint_mask``) and clusters with their own crack
        plane (``plane_free``, whose plane :meth:`set_crack_planes` set first) are always
        mapped as interfaces (their contact directions are not the sub-edge ones)."""
        idx = np.asarray(idx, dtype=np.int64)
        mapped = self.joint_mask | self.plane_free
        if not interface and idx.size and mapped[idx].any():
            j = mapped[idx]
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
                if self.plane_free[c]:
                    # the stress of the plane's operators (with the face couple)
                    pts = self.mesh.nodes[self.mesh.triangles[c]][None]
                    Sn = operator_stress(self.bn_c[c][None], pts, self.area[c:c + 1])[0]
                    Ss = operator_stress(self.bs_c[c][None], pts, self.area[c:c + 1])[0]
                    A = np.empty((3, 6))
                    A[:, 0::2], A[:, 1::2] = Sn.T, Ss.T
                    Fn_new[k], Fs_new[k] = self._joint_forces(c, A, s_target[k])
                    continue
                x, *_ = np.linalg.lstsq(A, s_target[k], rcond=None)
                Fn_new[k] = x[0::2]
                Fs_new[k] = x[1::2]
            F, Fs = Fn_new, Fs_new
        else:
            Fs = np.zeros_like(F)
        Un = np.einsum("cmi,ci->cm", self.bn_c[idx], uc)
        Us = np.einsum("cmi,ci->cm", self.bs_c[idx], uc)
        ref_n[idx] = Un - self._gap_of_force(F, idx)
        ref_s[idx] = Us - Fs / self.ks[idx]
        return ref_n, ref_s

    def _joint_forces(self, c: int, A: np.ndarray, s_target: np.ndarray):
        """Contact forces of a cluster failing onto its own crack plane that reproduce its
        effective stress ``s_target`` (columns ``A``: stress of a unit normal / shear force
        of each contact, interleaved).

        The crossing contacts carry one joint traction, ``F_n = l_m sigma_J`` and
        ``F_s = l_m tau_J`` (``l_m`` the joint lengths), so the crack is closed evenly
        under the stress normal to it; the third contact the rest. The four unknowns
        ``(l sigma_J, l tau_J, F_n3, F_s3)`` (``l`` the mean joint length) are the
        least-norm solution of the three stress components. (The least-norm solution over
        all six forces, kept for preset planes and interfaces, can put one crossing
        contact in tension and another in extra compression: the crack would open in part
        at failure under a compressive stress normal to it.)
        """
        jt = self.joint[c]
        ell = self.ell[c]
        lbar = float(np.mean(ell[jt]))
        An, As = A[:, 0::2], A[:, 1::2]
        cols = [An[:, jt] @ ell[jt] / lbar, As[:, jt] @ ell[jt] / lbar]
        rest = np.flatnonzero(~jt)
        for m in rest:
            cols += [An[:, m], As[:, m]]
        x, *_ = np.linalg.lstsq(np.array(cols).T, s_target, rcond=None)
        fn = np.zeros(3)
        fs = np.zeros(3)
        fn[jt] = ell[jt] * x[0] / lbar
        fs[jt] = ell[jt] * x[1] / lbar
        fn[rest] = x[2::2]
        fs[rest] = x[3::2]
        return fn, fs

    def _commit_slip(self, resp, ref_s, slip, cstate):
        """After a converged step: move shear references by the frictional slip."""
        Fn, Fs, status, Un, Us = resp
        failed = (cstate != INTACT)[:, None]
        # a sticking contact keeps its reference (Us - Fs/ks is it, up to the round-off
        # that would otherwise accumulate as spurious slip)
        new_ref = np.where(status == OPEN, Us,
                           np.where(status == STICK, ref_s, Us - Fs / self.ks))
        new_ref = np.where(failed, new_ref, ref_s)
        dslip = np.where(failed & (status != OPEN), new_ref - ref_s, 0.0)
        return new_ref, slip + np.abs(dslip)

    def fail_clusters(self, state: MechanicsState, clusters: np.ndarray,
                      mode: int = PRESET,
                      plane_normal: np.ndarray | None = None) -> MechanicsState:
        """Return a copy of ``state`` with ``clusters`` switched to a failed state.

        The contact forces of the switched clusters equal those of their current stress
        (no jump); use :meth:`step` afterwards to re-equilibrate. Used to pre-cut cracks.
        With :class:`CrackPlanes` the clusters get the crack plane ``plane_normal``
        ((2,) or one per cluster, unit normal), default the tensile plane of their stress.
        """
        idx = np.unique(np.asarray(clusters, dtype=np.int64))
        if idx.size and (idx.min() < 0 or idx.max() >= self.mesh.n_triangles):
            raise InputError("cluster index out of range", key="clusters")
        cstate = np.array(state.cluster_state)
        keep = cstate[idx] == INTACT
        if plane_normal is not None:
            pn = np.asarray(plane_normal, dtype=float)
            if pn.shape not in ((2,), (len(idx), 2)) or not np.all(np.isfinite(pn)) or \
                    np.any(np.linalg.norm(pn.reshape(-1, 2), axis=1) == 0.0):
                raise InputError("must be a non-zero (2,) vector or one per cluster",
                                 key="plane_normal")
            plane_normal = pn if pn.ndim == 1 else pn[keep]
        idx = idx[keep]
        self.sync_planes(cstate, state.crack_normal)
        cn = self.set_crack_planes(idx, np.ones(len(idx), dtype=bool),
                                   np.asarray(state.effective_stress), cstate,
                                   np.asarray(state.crack_normal), plane_normal)
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
                                (Fn, Fs, status, Un, Us), cn)

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
        cn = np.array(state.crack_normal)
        self.sync_planes(cstate, cn)
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
            trial = self._make_state(u, cstate, ref_n, ref_s, slip, p, pw, resp, cn)
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
            cn = self.set_crack_planes(cand, tens[cand], np.asarray(trial.effective_stress),
                                       cstate, cn)
            ref_n, ref_s = self._contact_refs(cand, u, p, ref_n, ref_s)
            cstate[cand] = np.where(tens[cand], FAILED_TENSILE, FAILED_SHEAR)
            new.extend(int(c) for c in cand)
        if ok:
            ref_s, slip = self._commit_slip(resp, ref_s, slip, cstate)
        st = self._make_state(u, cstate, ref_n, ref_s, slip, p, pw, resp, cn)
        return MechanicsResult(state=st, converged=ok, reason=why, iterations=total_it,
                               failure_rounds=rounds,
                               new_failures=np.array(new, dtype=np.int64))

    # ------------------------------------------------------------------ coupling
    def tangent(self, state: MechanicsState):
        """Reduced tangent stiffness (free DOFs) at ``state``, scipy CSR [N/m^2]."""
        self.sync_planes(state.cluster_state, state.crack_normal)
        _, _, status, sgn, _, Un, _ = self._response(
            np.asarray(state.displacement), np.asarray(state.cluster_state),
            np.asarray(state.ref_normal), np.asarray(state.ref_shear),
            np.asarray(state.pore_pressure))
        blocks = self._tangent_blocks(np.asarray(state.cluster_state), status, sgn,
                                      kn=self.normal_stiffness(Un - np.asarray(state.ref_normal)))
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


