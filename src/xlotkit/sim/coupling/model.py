"""Monolithic implicit hydro-mechanical model: nodal displacements, cell pressures, well
pressure, with failed (cracked) clusters in the same Newton system.

SPEC §5, coupling strategy ``monolithic``; derivations and measurements in
``docs/coupling.md``.

Unknowns ``x = (u_f, p, p_w)``: the free nodal displacements ``u_f`` (the mechanics' free
DOFs minus any extra constraints given here), one pressure per triangle and the borehole
pressure. Residuals of a backward-Euler step ``t_n -> t_{n+1} = t_n + dt``:

Mechanics, per unit thickness [N/m]::

    R_u = sum_c [f_c(u, p) - f_c(u_0, p_0)] - f_w (p_w - p_w0) - L(t_{n+1})

``f_c`` is the cluster's internal force of :meth:`MechanicsModel._response`: for an intact
cluster the linear (CST-equivalent) MDEM force with the Biot pressure ``-alpha p g_c``
(evaluated in the exact incremental form ``k_c (u - u_0)_c - alpha (p - p_0) g_c``); for a
failed cluster the contact law (open contacts carry nothing, closed ones ``k_n g`` and
Coulomb friction) and the fluid pressure with coefficient 1. Index 0 is the in-situ
equilibrium of :meth:`MechanicsModel.initial_state`, so for intact rock this is the
incremental poroelastic residual of the first increment, unchanged. ``f_w`` is the nodal
load of a unit wall pressure (``p_w`` is the wall traction) and ``L`` an extra load.

Flow, per cell [kg/s]: :meth:`FlowModel.residual_and_jacobian` with

* the extra pore volume ``V^x_c = coef_c h (g_c . (u - u_0)_c) + V^off_c`` (``coef = alpha``
  intact, 1 failed; ``g_c . du_c = A_c eps_vol,c``): the Biot skeleton volume change of an
  intact cluster, the *whole* area change of a failed one. The crack's volume is part of
  that area change and is counted there once (never again from the aperture); ``V^off``
  is zero unless ``failure_dilatation="continuous"``, which sets it when a cluster fails
  so that ``V^x`` is continuous across the switch of ``coef``;
* the permeability of a failed cluster ``k = k_m + w_h^3 / (12 Delta)`` (cubic law
  up-scaled, Eq. 4.2-4.3, :func:`~xlotkit.sim.flow.fracture.crack_permeability`) with the
  hydraulic aperture ``w_h = w_res + w_n``, ``w_n`` the largest contact gap of the cluster
  (:func:`~xlotkit.sim.flow.fracture.crack_opening`); faces use harmonic transmissibility;
* the well: storage ``C_w = C_seg + h c_well`` (the segment's own hole volume times
  ``c_f`` plus an optional extra well compliance ``c_well`` per unit height) and the hole's
  enlargement ``V^x_w = h f_w . (u - u_0)`` as extra well volume; the rate ``Q(t)`` (or a
  ``p_w``-dependent rate, e.g. a choke) metered at the reference density.

Jacobian::

    [ K(active set)             G(coef)     -f_w ]
    [ diag(rho/dt) dV^x/du
      + dR/dk dk/du             J_flow           ]
    [ (rho_w/dt) h f_w^T                          ]

``K`` is the mechanics' tangent for the current contact statuses
(:meth:`MechanicsModel._tangent_blocks`), ``G`` the pressure-load operator with the
cluster coefficients (:meth:`MechanicsModel.pressure_load`), ``dV^x/du = -h G^T`` (the
same operator: reciprocal), ``dR/dk`` from :meth:`FlowModel.d_residual_d_permeability`
and ``dk/du = (w_h^2 / 4 Delta) b_n`` of the active contact.

Sign convention: displacements as in the mechanics (from the pre-drilling state);
stresses returned compression positive.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import scipy.sparse as sp

from xlotkit.errors import InputError
from xlotkit.sim.coupling.assembly import (
    CoupledLayout,
    CoupledPattern,
    add_crack_block,
    assemble_jacobian,
    cluster_forces,
    hold_rows,
)
from xlotkit.sim.flow import FlowModel, FlowState
from xlotkit.sim.flow.fracture import (
    cluster_length_scale,
    crack_fields,
    crack_opening,
    crack_permeability,
    crack_permeability_derivative,
    hydraulic_aperture,
    sealing_aperture,
    sealing_aperture_derivative,
)
from xlotkit.sim.mechanics import (
    FAILED_SHEAR,
    FAILED_TENSILE,
    INTACT,
    PRESET,
    OPEN,
    SLIP,
    MechanicsModel,
    MechanicsState,
)
from xlotkit.sim.mechanics.assembly import edge_traction_load
from xlotkit.sim.mechanics.mdem import cst_b_matrix
from xlotkit.sim.mesh import Mesh

__all__ = [
    "CoupledModel",
    "CoupledResidual",
    "CoupledState",
    "WellRateFunction",
    "biot_modulus",
    "boundary_load",
    "drained_bulk_modulus",
    "grain_pore_compressibility",
]

LoadFunction = Callable[[float], np.ndarray]
WellRateFunction = Callable[[float, float], "float | tuple[float, float]"]


# --------------------------------------------------------------------------- helpers
def drained_bulk_modulus(young: float, poisson: float) -> float:
    """Drained (3D) bulk modulus ``K = E / (3 (1 - 2 nu))`` [Pa]."""
    return young / (3.0 * (1.0 - 2.0 * poisson))


def grain_pore_compressibility(biot: float, porosity, young: float, poisson: float):
    """Pore compressibility ``c_r`` [1/Pa] to give the flow model when the skeleton's
    volume change is coupled: only the grain term, ``phi c_r = (alpha - phi) / K_s`` with
    ``K_s = K / (1 - alpha)`` the grain bulk modulus.

    Returns 0 for ``alpha = 1`` (incompressible grains). Raises if ``alpha < phi`` (no
    admissible grain modulus).
    """
    phi = np.asarray(porosity, dtype=float)
    if np.any(biot < phi):
        raise InputError(f"Biot coefficient {biot} is below the porosity", key="rock.biot",
                         expected=">= porosity")
    K = drained_bulk_modulus(young, poisson)
    c = (biot - phi) * (1.0 - biot) / (phi * K)
    return float(c) if np.ndim(c) == 0 else c


def biot_modulus(biot: float, porosity: float, fluid_compressibility: float, young: float,
                 poisson: float) -> float:
    """Biot modulus ``M`` [Pa]: ``1/M = phi c_f + (alpha - phi)/K_s``, ``K_s = K/(1-alpha)``."""
    K = drained_bulk_modulus(young, poisson)
    inv = porosity * fluid_compressibility + (biot - porosity) * (1.0 - biot) / K
    return 1.0 / inv


def boundary_load(mesh: Mesh, tags, stress) -> np.ndarray:
    """Consistent nodal forces [N/m] (shape ``(2 n,)``) of a uniform *compression-positive*
    stress change ``stress`` (2x2, or a scalar for ``s I``) acting on the boundary edges with
    the given tags (a surface load step: ``stress = q`` on ``TOP``)."""
    s = np.asarray(stress, dtype=float)
    S = s * np.eye(2) if s.ndim == 0 else s
    if S.shape != (2, 2):
        raise InputError("stress must be a scalar or 2x2", key="stress")
    sel = np.isin(mesh.boundary_tags, np.atleast_1d(np.asarray(tags, dtype=np.int64)))
    return edge_traction_load(mesh.nodes, mesh.boundary_edges[sel], -S)


def _median(a: np.ndarray) -> float:
    """``np.median`` of a 1D array (the mean of the two middle values for an even
    length), by partition: the same number without numpy's general-purpose overhead."""
    n = len(a)
    h = n // 2
    if n % 2:
        return float(np.partition(a, h)[h])
    q = np.partition(a, (h - 1, h))
    return float(0.5 * (q[h - 1] + q[h]))


# --------------------------------------------------------------------------- state
def _ro(a, dtype=float) -> np.ndarray:
    if (isinstance(a, np.ndarray) and a.dtype == dtype and not a.flags.writeable
            and a.base is None):
        # already a read-only array that owns its data (another state's): shared
        return a
    a = np.array(a, dtype=dtype, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class CoupledState:
    """State of the coupled model at one time (read-only arrays).

    Attributes
    ----------
    displacement : ndarray (n_nodes, 2) [m]
        From the pre-drilling state (as :class:`MechanicsState`).
    flow : FlowState
        Time, cell pressures, well pressure, the skeleton's extra pore volume ``V^x``
        (n_c,) [m^3] and the hole's volume change (``flow.well_extra_volume``) [m^3].
    applied_load : ndarray (2 n_nodes,) [N/m]
        Extra external nodal load the state is in equilibrium with.
    mechanics : MechanicsState, optional
        The mechanics' view of the state (stresses, contact forces, statuses, gaps,
        cluster states, contact references, slip). Set by the model for every state it
        builds; ``None`` only for a bare state, which then means intact rock.
    volume_offset : ndarray (n_c,) [m^3], optional
        ``V^off``: keeps ``V^x`` continuous when a cluster's pressure coefficient switches
        from ``alpha`` to 1 at failure (zero for ``alpha = 1``); ``None`` = zeros.
    failure_time : ndarray (n_c,) [s], optional
        Time at which each cluster failed (``nan``: intact or failed before the start).
    failure_volume : ndarray (n_c,) [m^3], optional
        ``V^x`` of each cluster when it failed (0 otherwise); ``V^x - failure_volume`` of
        a failed cluster is the pore (crack) volume it opened since.
    """

    displacement: np.ndarray
    flow: FlowState
    applied_load: np.ndarray
    mechanics: MechanicsState | None = None
    volume_offset: np.ndarray | None = None
    failure_time: np.ndarray | None = None
    failure_volume: np.ndarray | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "displacement", _ro(self.displacement))
        object.__setattr__(self, "applied_load", _ro(self.applied_load))
        m = len(self.flow.p)
        vo = np.zeros(m) if self.volume_offset is None else self.volume_offset
        ft = np.full(m, np.nan) if self.failure_time is None else self.failure_time
        fv = np.zeros(m) if self.failure_volume is None else self.failure_volume
        object.__setattr__(self, "volume_offset", _ro(vo))
        object.__setattr__(self, "failure_time", _ro(ft))
        object.__setattr__(self, "failure_volume", _ro(fv))

    @property
    def t(self) -> float:
        """Time [s]."""
        return self.flow.t

    @property
    def p(self) -> np.ndarray:
        """Cell pressures [Pa], shape (n_c,)."""
        return self.flow.p

    @property
    def p_w(self) -> float:
        """Well pressure [Pa]."""
        return self.flow.p_w

    @property
    def cluster_state(self) -> np.ndarray:
        """Cluster states (``INTACT``, ``FAILED_TENSILE``, ...), shape (n_c,)."""
        if self.mechanics is None:
            return np.zeros(len(self.flow.p), dtype=np.int64)
        return np.asarray(self.mechanics.cluster_state)

    @property
    def n_failed(self) -> int:
        """Number of failed clusters (tensile, shear or preset)."""
        cs = self.cluster_state
        return int(np.sum((cs == FAILED_TENSILE) | (cs == FAILED_SHEAR) | (cs == PRESET)))


@dataclass(frozen=True, eq=False)
class Structure:
    """The non-smooth history a Newton solve works with (read-only arrays).

    Attributes
    ----------
    cluster_state : ndarray of int (n_c,)
    ref_normal, ref_shear : ndarray (n_c, 3) [m]
        Contact references of failed clusters (as :class:`MechanicsState`).
    slip : ndarray (n_c, 3) [m]
        Committed frictional slip.
    volume_offset : ndarray (n_c,) [m^3]
    failure_time : ndarray (n_c,) [s]
    failure_volume : ndarray (n_c,) [m^3]
    crack_normal : ndarray (n_c, 2), optional
        Crack plane of each failed cluster (as :class:`MechanicsState`); None = zeros.
    """

    cluster_state: np.ndarray
    ref_normal: np.ndarray
    ref_shear: np.ndarray
    slip: np.ndarray
    volume_offset: np.ndarray
    failure_time: np.ndarray
    failure_volume: np.ndarray
    crack_normal: np.ndarray | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "cluster_state", _ro(self.cluster_state, np.int64))
        if self.crack_normal is None:
            object.__setattr__(self, "crack_normal", np.zeros((len(self.cluster_state), 2)))
        for k in ("ref_normal", "ref_shear", "slip", "volume_offset", "failure_time",
                  "failure_volume", "crack_normal"):
            object.__setattr__(self, k, _ro(getattr(self, k)))


@dataclass(frozen=True, eq=False)
class CoupledResidual:
    """Residual and Jacobian of the coupled system at one iterate.

    Attributes
    ----------
    residual : ndarray (n_u + m + 1,)
        ``(R_u [N/m], R_f [kg/s], R_w [kg/s])``.
    jacobian : scipy.sparse.csr_matrix or None
        None for a residual-only evaluation (:meth:`CoupledModel.residual`).
    force_scale : float
        Scale of the mechanical terms [N/m] for the relative tolerance.
    mass_scale : float
        Scale of the step's mass rates [kg/s]: the flow throughput plus the gross storage
        terms (skeleton/crack volume change and fluid/grain compression, which cancel in
        an undrained step).
    flow : FlowResidual
        The flow part with its mass diagnostics.
    state : CoupledState
        The iterate as a state (its ``mechanics`` is filled only by
        :meth:`CoupledModel.finish_state`).
    response : tuple
        ``(Fn, Fs, status, Un, Us)`` of the contacts at the iterate.
    permeability : ndarray (m,) [m^2]
        Cell permeabilities used.
    pattern : CoupledPattern or None
        The sparsity pattern the Jacobian is stored on (the same object while the failed
        clusters are the same: the linear solver reuses its ordering on it).
    status : ndarray of int (m, 3) or None
        Contact statuses the Jacobian was linearised with (held branches included).
    """

    residual: np.ndarray
    jacobian: sp.csr_matrix | None
    force_scale: float
    mass_scale: float
    flow: object
    state: CoupledState
    response: tuple
    permeability: np.ndarray
    pattern: CoupledPattern | None = None
    status: np.ndarray | None = None


# --------------------------------------------------------------------------- model
class CoupledModel:
    """Hydro-mechanical model: a :class:`MechanicsModel` and a :class:`FlowModel` on the
    same mesh, solved together, with cluster failure and fracture flow.

    Parameters
    ----------
    mechanics : MechanicsModel
    flow : FlowModel
        Its ``rock.pore_compressibility`` must hold only the grain term
        (:func:`grain_pore_compressibility`); its ``height`` is the segment height ``h``;
        its ``well.storage`` (default the segment hole volume times ``c_f``) is the
        segment's own well storage.
    fixed_dofs : array of int, optional
        Displacement DOFs (``2 k`` = x, ``2 k + 1`` = y of node ``k``) held at their initial
        value in addition to the mechanics' boundary conditions.
    load : ndarray (2 n,) or callable ``t -> ndarray``, optional
        Extra external nodal load [N/m] (relative to the in-situ state).
    check_storage : bool
        Refuse a pore compressibility above the grain term (double counting).
    residual_aperture : float
        ``w_res`` [m] of failed clusters (a closed crack's hydraulic aperture).
    dilation_angle : float, optional
        Shear-dilation angle ``psi`` [rad] in ``(0, pi/2)``: a failed cluster's hydraulic
        aperture gains ``tan(psi) |u_s|``, ``u_s`` the largest committed slip of its
        contacts (thesis 4.7.2: asperities riding over each other keep a sheared crack
        hydraulically open after it closes mechanically). ``None`` (default): no dilation.
        The slip is the one committed at the start of the step (lagged), so the term adds
        no Jacobian entries.
    length_scale : float or ndarray (m,), optional
        ``Delta`` [m] of Eq. 4.3; default ``sqrt(A)`` per cell.
    well_compliance : float
        Extra well compliance per unit segment height [m^3/(Pa m)] (the rest of the well;
        ``C_w = flow.well_storage + h * well_compliance``). Default 0.
    well_rate : callable ``(t, p_w) -> Q`` or ``-> (Q, dQ/dp_w)``, optional
        Injection rate [m^3/s at the reference density, per segment] as a function of the
        step midpoint time and the (implicit) well pressure; overrides ``flow.well.rate``.
        Returning 0 is a shut-in; a choke is ``Q = -zeta sqrt(p_w - p_atm)`` with its
        derivative. Without it the flow's ``WellCondition.rate`` (a number or ``t -> Q``)
        applies.
    hole_volume_change : bool
        Include the hole's enlargement by the wall displacement in the well storage.
    failure_dilatation : {"pore", "continuous"}
        What a cluster's dilatation becomes when it fails and its pressure coefficient
        switches from ``alpha`` to 1 (the two agree for ``alpha = 1``). ``"pore"``
        (default): from then on its whole area change since the in-situ state is pore
        volume, ``V^x = h A eps_vol``. The elastic stretch a crack-tip cluster carries
        before it breaks is the crack-opening displacement near the tip of the continuum
        crack, so it belongs to the crack volume; the fluid in the cluster then fills it
        (its pressure drops by the jump in ``V^x`` and flow refills it, mass conserved).
        ``"continuous"``: ``V^off = (alpha - 1) h A eps_vol`` keeps ``V^x`` continuous,
        so only the opening after failure is pore volume; with ``alpha < 1`` this leaves
        the pre-failure stretch out of the crack and the crack grows too long for the
        fluid injected (KGD: +12 % in length, docs/coupling.md).
    """

    def __init__(self, mechanics: MechanicsModel, flow: FlowModel, *, fixed_dofs=None,
                 load: np.ndarray | LoadFunction | None = None,
                 check_storage: bool = True, residual_aperture: float = 1e-6,
                 length_scale=None, well_compliance: float = 0.0,
                 well_rate: WellRateFunction | None = None,
                 hole_volume_change: bool = True,
                 failure_dilatation: str = "pore",
                 dilation_angle: float | None = None) -> None:
        if not isinstance(mechanics, MechanicsModel):
            raise InputError("expected a MechanicsModel", key="mechanics")
        if not isinstance(flow, FlowModel):
            raise InputError("expected a FlowModel", key="flow")
        mesh = mechanics.mesh
        if (flow.mesh.n_triangles != mesh.n_triangles or flow.mesh.n_nodes != mesh.n_nodes
                or not np.array_equal(flow.mesh.triangles, mesh.triangles)
                or not np.allclose(flow.mesh.nodes, mesh.nodes, rtol=0, atol=1e-12)):
            raise InputError("mechanics and flow must use the same mesh", key="flow.mesh")
        if not (math.isfinite(residual_aperture) and residual_aperture >= 0):
            raise InputError("must be finite and >= 0", key="coupling.residual_aperture")
        if not (math.isfinite(well_compliance) and well_compliance >= 0):
            raise InputError("must be finite and >= 0", key="coupling.well_compliance")
        if well_rate is not None and not callable(well_rate):
            raise InputError("must be a callable (t, p_w) -> Q or (Q, dQ/dp_w)",
                             key="coupling.well_rate")
        if well_rate is not None and flow.well.pressure_controlled:
            raise InputError("the flow's well is pressure controlled",
                             key="coupling.well_rate")
        if dilation_angle is not None and not (0.0 < float(dilation_angle) < 0.5 * math.pi):
            raise InputError(f"value {dilation_angle!r} rad is out of range",
                             key="coupling.dilation_angle", expected="(0, pi/2) rad or None")
        if failure_dilatation not in ("pore", "continuous"):
            raise InputError(f"unknown value {failure_dilatation!r}",
                             key="coupling.failure_dilatation",
                             expected="'pore' or 'continuous'")
        self.mechanics = mechanics
        self.flow = flow
        self.failure_dilatation = failure_dilatation
        self.mesh = mesh
        self.height = float(flow.height)
        self.biot = float(mechanics.rock.biot)
        self.residual_aperture = float(residual_aperture)
        self.dilation_angle = None if dilation_angle is None else float(dilation_angle)
        self.well_compliance = float(well_compliance)
        self.well_rate = well_rate
        self.hole_volume_change = bool(hole_volume_change)
        self.well_storage = float(flow.well_storage) + self.height * self.well_compliance
        rock = mechanics.rock
        if check_storage:
            phi = np.asarray(flow.porosity)
            if np.any(self.biot < phi):
                raise InputError("Biot coefficient below the porosity", key="rock.biot",
                                 expected=">= porosity")
            c_max = np.min(grain_pore_compressibility(self.biot, phi, rock.young,
                                                      rock.poisson))
            cr = flow.rock.pore_compressibility
            if cr > c_max * (1.0 + 1e-9) + 1e-30:
                raise InputError(
                    f"pore compressibility {cr:g} 1/Pa exceeds the grain term {c_max:g} 1/Pa: "
                    "the drained pore compressibility is already in alpha*eps_vol "
                    "(double counting)", key="flow.rock.pore_compressibility",
                    expected=f"<= {c_max:g} (grain_pore_compressibility)")
        n_dof = mechanics.n_dof
        free = np.array(mechanics.free, dtype=bool)
        mech_index = np.cumsum(free) - 1      # reduced index of the mechanics' free DOFs
        if fixed_dofs is not None:
            fd = np.unique(np.asarray(fixed_dofs, dtype=np.int64))
            if fd.size and (fd.min() < 0 or fd.max() >= n_dof):
                raise InputError("DOF index out of range", key="fixed_dofs")
            free[fd] = False
        self.free = free
        self.free_dofs = np.flatnonzero(free)
        self._sel = mech_index[self.free_dofs]   # rows/cols of the mechanics' reduced K
        self._sel_all = len(self._sel) == int(np.sum(mechanics.free))
        # reduced unknown of every mechanics DOF (-1: held), for the tangent assembly
        unknown = -np.ones(n_dof, dtype=np.int64)
        unknown[self.free_dofs] = np.arange(len(self.free_dofs))
        self._unknown = unknown
        self._g_cache: tuple[bytes, sp.csr_matrix] | None = None
        self.n_u = len(self.free_dofs)
        self.n_cells = mesh.n_triangles
        self.n_unknowns = self.n_u + self.n_cells + 1
        # a constant load (not a function of time): its free-DOF part and its scale are
        # computed once (_evaluate)
        self._load_const: tuple | None = None
        if callable(load):
            self._load = load
        else:
            f = np.zeros(n_dof) if load is None else np.asarray(load, dtype=float)
            if f.shape != (n_dof,):
                raise InputError(f"load must have shape ({n_dof},)", key="load")
            f = f.copy()
            f.setflags(write=False)
            self._load = lambda t, _f=f: _f
            lf = f[self.free_dofs]
            self._load_const = (f, lf, float(np.max(np.abs(lf), initial=0.0)))
        if length_scale is None:
            self.length_scale = cluster_length_scale(mesh.areas)
        else:
            self.length_scale = np.broadcast_to(
                np.asarray(length_scale, dtype=float), (self.n_cells,)).copy()
            if np.any(~np.isfinite(self.length_scale)) or np.any(self.length_scale <= 0):
                raise InputError("must be finite and > 0", key="coupling.length_scale")
        self.mech_state0: MechanicsState | None = None
        self._B = cst_b_matrix(mesh.nodes, mesh.triangles)
        # unit pressure load: column c holds -g_c = -A_c B_c^T (1, 1, 0) on dofs[c]
        nc = self.n_cells
        self._g = np.asarray(mechanics.g_pressure, dtype=float)
        dofs = np.asarray(mechanics.dofs)
        self._G_unit = sp.csr_matrix((-self._g.ravel(), (dofs.ravel(),
                                                         np.repeat(np.arange(nc), 6))),
                                     shape=(n_dof, nc))[self.free_dofs].tocsr()
        self.f_wall = np.asarray(mechanics.f_wall, dtype=float)[self.free_dofs]
        self._f_wall_max = float(np.max(np.abs(self.f_wall), initial=0.0))
        # per set of cluster states: the pressure coefficients, the G entries and the
        # failed clusters' reference force scale (they change only when clusters fail)
        self._cs_memo: tuple[bytes, tuple] | None = None
        # where every entry of the Jacobian goes (the pattern per set of failed clusters)
        self.layout = CoupledLayout(
            dofs, unknown, self.n_u, self.f_wall, flow.jacobian_triplets,
            flow.permeability_triplets,
            well_row_permeability=flow.has_well and not flow.well.pressure_controlled,
            biot_blocks=self.biot > 0.0)
        self._wall_rows = self.layout.wall_rows
        self._wall_column = -self.f_wall[self._wall_rows]
        self._wall_column.setflags(write=False)

    # ---------------------------------------------------------------- setup
    def initial_state(self, mechanics_state: MechanicsState | None = None,
                      p_w: float | None = None, t: float = 0.0) -> CoupledState:
        """Coupled state at the in-situ equilibrium (drilled hole, uniform ``p0``).

        The mechanics' initial equilibrium (:meth:`MechanicsModel.initial_state`, or the one
        given, e.g. with pre-cut clusters from :meth:`MechanicsModel.fail_clusters`) is the
        reference state ``(u_0, p_0, p_w0)`` of the incremental residual. Pre-failed
        clusters of a given state keep their contact references.
        """
        m = self.mechanics
        ms = m.initial_state(p_w) if mechanics_state is None else mechanics_state
        m.sync_planes(ms.cluster_state, ms.crack_normal)
        self.mech_state0 = ms
        self.u0 = np.asarray(ms.displacement, dtype=float).reshape(-1).copy()
        self._u0_free = self.u0[self.free_dofs]
        self.p0 = np.asarray(ms.pore_pressure, dtype=float).copy()
        self.pw0 = float(ms.wall_pressure)
        cs0 = np.asarray(ms.cluster_state)
        # reference internal forces of every cluster at (u0, p0): for clusters in a contact
        # state at the start, from their own law; for intact ones from the intact law
        nc = self.n_cells
        *_, fc_int, _, _ = m._response(ms.displacement, np.zeros(nc, dtype=np.int64),
                                       np.zeros((nc, 3)), np.zeros((nc, 3)), self.p0)
        *_, fc_now, _, _ = m._response(ms.displacement, cs0, np.asarray(ms.ref_normal),
                                       np.asarray(ms.ref_shear), self.p0)
        self._fc0 = np.where((cs0 != INTACT)[:, None], fc_now, fc_int)
        self._cs_memo = None
        self._cs0 = cs0.copy()
        fs = self.flow.initial_state(self.p0, p_w=self.pw0, t=t)
        return CoupledState(self.u0.reshape(-1, 2), fs, np.zeros(m.n_dof), mechanics=ms)

    def _require_init(self) -> None:
        if self.mech_state0 is None:
            raise RuntimeError("call initial_state() first")

    # ---------------------------------------------------------------- vectors
    def x_of(self, state: CoupledState) -> np.ndarray:
        """Unknown vector ``(u_f, p, p_w)`` of a state."""
        u = np.asarray(state.displacement).reshape(-1)[self.free_dofs]
        return np.concatenate([u, state.p, [state.p_w]])

    def load_at(self, t: float) -> np.ndarray:
        """Extra external nodal load at ``t`` [N/m], shape (2 n,)."""
        f = np.asarray(self._load(t), dtype=float)
        if f.shape != (self.mechanics.n_dof,):
            raise InputError(f"load(t) must have shape ({self.mechanics.n_dof},)", key="load")
        return f

    def structure_of(self, state: CoupledState) -> Structure:
        """The contact/failure history of a state as a :class:`Structure`."""
        ms = state.mechanics if state.mechanics is not None else self.mech_state0
        return Structure(ms.cluster_state, ms.ref_normal, ms.ref_shear, ms.slip,
                         state.volume_offset, state.failure_time, state.failure_volume,
                         ms.crack_normal)

    def coefficients(self, cluster_state: np.ndarray) -> np.ndarray:
        """Pressure coefficient of each cluster: ``alpha`` intact, 1 otherwise, (n_c,)."""
        return np.where(np.asarray(cluster_state) != INTACT, 1.0, self.biot)

    def pressure_operator(self, cluster_state: np.ndarray) -> sp.csr_matrix:
        """``G`` (n_u x m) [m]: nodal forces of unit cluster pressures (free DOFs).

        Cached for the last cluster states (they change only when clusters fail).
        """
        key = np.asarray(cluster_state).tobytes()
        if self._g_cache is not None and self._g_cache[0] == key:
            return self._g_cache[1]
        G = (self._G_unit @ sp.diags(self.coefficients(cluster_state))).tocsr()
        self._g_cache = (key, G)
        return G

    def state_of(self, x: np.ndarray, t: float, load: np.ndarray,
                 structure: Structure | None = None) -> CoupledState:
        """State of an unknown vector ``x`` at time ``t`` with the applied ``load``
        (``mechanics`` left empty; see :meth:`finish_state`)."""
        self._require_init()
        nu, m = self.n_u, self.n_cells
        st = structure
        u = self.u0.copy()
        u[self.free_dofs] = x[:nu]
        du = x[:nu] - self._u0_free
        cs = self._cs0 if st is None else st.cluster_state
        du_full = np.zeros(self.mechanics.n_dof)
        du_full[self.free_dofs] = du
        gdu = np.einsum("ci,ci->c", self._g, du_full[self.mechanics.dofs])
        cs = np.asarray(cs)
        vx = self.height * self._cluster_memo(cs, cs != INTACT)[0] * gdu
        if st is not None:
            vx = vx + st.volume_offset
        vw = self.height * float(self.f_wall @ du) if self.hole_volume_change else 0.0
        fs = FlowState(t, x[nu:nu + m], x[nu + m], vx, vw)
        return CoupledState(u.reshape(-1, 2), fs, load,
                            volume_offset=None if st is None else st.volume_offset,
                            failure_time=None if st is None else st.failure_time,
                            failure_volume=None if st is None else st.failure_volume)

    def finish_state(self, res: CoupledResidual, structure: Structure) -> CoupledState:
        """The converged iterate of ``res`` as a full state (with its mechanics view)."""
        s = res.state
        Fn, Fs, status, Un, Us = res.response
        ms = self.mechanics._make_state(
            np.asarray(s.displacement), np.array(structure.cluster_state),
            np.array(structure.ref_normal), np.array(structure.ref_shear),
            np.array(structure.slip), np.array(s.p), s.p_w, res.response,
            np.array(structure.crack_normal))
        return CoupledState(s.displacement, s.flow, s.applied_load, mechanics=ms,
                            volume_offset=structure.volume_offset,
                            failure_time=structure.failure_time,
                            failure_volume=structure.failure_volume)

    # ---------------------------------------------------------------- fracture flow
    def crack_permeability(self, cluster_state: np.ndarray, gap: np.ndarray,
                           slip: np.ndarray | None = None
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Cell permeability with the failed clusters' crack conductivity.

        The hydraulic aperture of a failed cluster is ``w_res + w_n`` and, with a
        :attr:`dilation_angle` and ``slip`` given, ``+ tan(psi) max_j |u_s,j|``
        (:func:`~xlotkit.sim.flow.fracture.hydraulic_aperture`). With a closure law
        (``mechanics.closure``) the ``w_res + w_n`` part is
        :func:`~xlotkit.sim.flow.fracture.sealing_aperture` of the largest signed gap of
        the cluster's joint contacts (``mechanics.joint``): it falls below its
        zero-stress value as the crack closes, down to the sealed aperture.

        Parameters
        ----------
        cluster_state : ndarray of int (m,)
        gap : ndarray (m, 3) [m]
            Contact openings (0 for closed contacts and intact clusters); with a closure
            law the signed gaps ``U_n - U_n^0`` (:meth:`contact_gap`).
        slip : ndarray (m, 3) [m], optional
            Committed contact slip; used only with a :attr:`dilation_angle`.

        Returns
        -------
        k : ndarray (m,) [m^2]
            ``k_m`` (intact) or ``k_m + w_h^3 / (12 Delta)`` (failed).
        dk_dw : ndarray (m,) [m]
            ``dk/dw_n`` (0 where the crack is closed or the cluster intact).
        opening : ndarray (m,) [m]
            ``w_n`` (largest contact gap) of failed clusters, 0 otherwise.
        active : ndarray of int (m,)
            Contact giving ``w_n``.
        """
        failed = np.asarray(cluster_state) != INTACT
        km = self.flow.permeability
        us = None
        if self.dilation_angle is not None and slip is not None:
            us = np.where(failed, np.max(np.abs(np.asarray(slip, dtype=float)), axis=1), 0.0)
        law = self.mechanics.closure
        if law.nonlinear:
            g = np.where(failed[:, None] & self.mechanics.joint,
                         np.asarray(gap, dtype=float), -np.inf)
            act = np.argmax(g, axis=1)
            gmax = g[np.arange(len(g)), act]
            gmax = np.where(np.isfinite(gmax), gmax, -float(law.max_closure))
            w0 = sealing_aperture(gmax, law.max_closure, law.sealed_aperture)
            live = failed & (sealing_aperture_derivative(gmax, law.max_closure) > 0)
            wn = np.maximum(gmax, 0.0)
            wh = hydraulic_aperture(np.zeros_like(w0), w0, us,
                                    None if us is None else self.dilation_angle)
        elif us is None:
            # the smooth law without dilation, in one compiled pass (the same numbers)
            return crack_fields(failed, gap, np.broadcast_to(km, failed.shape),
                                self.length_scale, self.residual_aperture)
        else:
            wn, act = crack_opening(np.where(failed[:, None], gap, 0.0))
            live = failed & (wn > 0)
            wh = hydraulic_aperture(wn, self.residual_aperture, us,
                                    None if us is None else self.dilation_angle)
        k = np.where(failed, crack_permeability(wh, km, self.length_scale), km)
        dk = np.where(live, crack_permeability_derivative(wh, self.length_scale), 0.0)
        return k, dk, np.where(failed, wn, 0.0), act

    def contact_gap(self, state: CoupledState) -> np.ndarray:
        """The gaps :meth:`crack_permeability` takes for a state, (m, 3) [m]: the
        openings of ``state.mechanics.gap`` (smooth law) or the signed gaps
        ``U_n - U_n^0`` of failed clusters' contacts (closure law; 0 when intact)."""
        ms = state.mechanics
        if ms is None:
            return np.zeros((self.n_cells, 3))
        if not self.mechanics.closure.nonlinear:
            return np.asarray(ms.gap)
        mech = self.mechanics
        mech.sync_planes(ms.cluster_state, ms.crack_normal)
        uc = np.asarray(state.displacement).reshape(-1)[mech.dofs]
        un = np.einsum("cmi,ci->cm", mech.bn_c, uc)
        failed = np.asarray(ms.cluster_state) != INTACT
        return np.where(failed[:, None], un - np.asarray(ms.ref_normal), 0.0)

    # ---------------------------------------------------------------- residual
    def residual_and_jacobian(self, x: np.ndarray, old: CoupledState, dt: float,
                              undrained: bool = False, structure: Structure | None = None,
                              soft: np.ndarray | None = None,
                              permeability_derivative: bool = True,
                              frozen: tuple | None = None) -> CoupledResidual:
        """Residual and Jacobian at the iterate ``x`` for the step from ``old``.

        Parameters
        ----------
        x : ndarray (n_u + m + 1,)
        old : CoupledState
            Converged state at ``t_n``.
        dt : float
            Step [s]. With ``undrained=True`` the step is instantaneous: no flow between
            cells, across the boundary or from the well (``t`` unchanged), and ``dt``
            only scales the rows.
        undrained : bool
        structure : Structure, optional
            Cluster states and contact references to use; default those of ``old``.
        soft : ndarray of bool (m, 3), optional
            Contacts linearised with their stick stiffness (chattering safeguard).
        permeability_derivative : bool
            Include ``dR_f/dk dk/du`` (the aperture dependence of the crack permeability)
            in the Jacobian; False gives the lagged-permeability (Picard) Jacobian. The
            residual is the same either way.
        frozen : tuple ``(mask, status, sign)`` of arrays (m, 3), optional
            Contacts whose law is held on one branch: where ``mask`` is set, the contact
            force follows the linear law of the given status (``OPEN``: no force;
            ``STICK``: ``k_n``/``k_s`` springs; ``SLIP``: normal spring and the Coulomb
            force ``sign mu (-F_n)``) whatever the trial forces, in the residual and the
            tangent alike. Where the iterate lies on that branch this is the exact law;
            elsewhere it is its linear continuation (active-set inner solve).

        Notes
        -----
        The Jacobian is summed into the fixed sparsity pattern of the present failed
        clusters (:mod:`xlotkit.sim.coupling.assembly`), so its structure is the same
        object from one iterate to the next while no cluster fails.
        """
        return self._evaluate(x, old, dt, undrained, structure, soft,
                              permeability_derivative, frozen, True)

    def residual(self, x: np.ndarray, old: CoupledState, dt: float,
                 undrained: bool = False, structure: Structure | None = None,
                 soft: np.ndarray | None = None,
                 frozen: tuple | None = None) -> CoupledResidual:
        """The residual alone at ``x`` (``jacobian`` None): what a line search's trial
        point needs. Same arguments and the same residual, scales, state and contact
        response as :meth:`residual_and_jacobian`."""
        return self._evaluate(x, old, dt, undrained, structure, soft, False, frozen, False)

    def _evaluate(self, x, old, dt, undrained, structure, soft, permeability_derivative,
                  frozen, jacobian: bool) -> CoupledResidual:
        self._require_init()
        mech = self.mechanics
        nu, m = self.n_u, self.n_cells
        st = self.structure_of(old) if structure is None else structure
        cs = np.asarray(st.cluster_state)
        failed = cs != INTACT
        t_new = old.t if undrained else old.t + dt
        load = self.load_at(t_new)
        it = self.state_of(x, t_new, load, st)
        u = np.asarray(it.displacement)
        p = np.asarray(it.p)
        du_full = u.reshape(-1) - self.u0
        dp = p - self.p0
        dpw = x[nu + m] - self.pw0
        ref_n = np.asarray(st.ref_normal)
        Fn, Fs, status, sgn, f_c, Un, Us = mech._response(
            u, cs, ref_n, np.asarray(st.ref_shear), p, frozen=frozen)
        coef, g_values, fc0_scale = self._cluster_memo(cs, failed)
        fint, fabs, _ = cluster_forces(mech.dofs, du_full, failed, f_c, self._fc0,
                                       mech.k_intact, coef, dp, self._g, mech.n_dof)
        fint = fint[self.free_dofs]
        lc = self._load_const
        if lc is not None and load is lc[0]:
            Lf, l_max = lc[1], lc[2]
        else:
            Lf = load[self.free_dofs]
            l_max = float(np.max(np.abs(Lf), initial=0.0))
        Ru = fint - self.f_wall * dpw - Lf
        force_scale = max(float(np.max(fabs[self.free_dofs], initial=0.0)),
                          self._f_wall_max * abs(dpw), l_max, 1e-300)
        if fc0_scale is not None:
            # failed clusters' forces are differences of absolute contact forces; the
            # scale must not drop below their round-off (1e-4 x their size -> the 1e-10
            # tolerance is 1e-14 of the absolute forces, a few ulps of the sums)
            force_scale = max(force_scale, fc0_scale)
        # fracture permeability: the openings (smooth law) or the signed gaps (closure
        # law: a closed crack's hydraulic aperture follows its normal stress)
        g_n = Un - ref_n
        gap = np.where(failed[:, None],
                       g_n if mech.closure.nonlinear else np.maximum(g_n, 0.0), 0.0)
        k, dk_dw, wn, act = self.crack_permeability(cs, gap, st.slip)
        kw: dict = dict(permeability=k, well_storage=self.well_storage)
        if undrained:
            kw.update(permeability=np.zeros(m), well_rate=0.0)
        elif self.well_rate is not None:
            q = self.well_rate(old.t + 0.5 * dt, float(x[nu + m]))
            kw["well_rate"] = (float(q), 0.0) if np.ndim(q) == 0 else tuple(map(float, q))
        fr = self.flow.residual_and_jacobian(it.flow, old.flow, dt,
                                             jacobian="values" if jacobian else "none", **kw)
        J = pattern = None
        if jacobian:
            # mechanics tangent for the current statuses, the coupling blocks and the
            # flow, summed into the pattern of the present failed clusters
            pattern = self.layout.pattern(failed)
            blocks = mech._tangent_blocks(cs, status, sgn, soft, mech.normal_stiffness(g_n))
            rho_dt = np.asarray(fr.d_residual_d_extra_volume)
            wr = self._wall_rows
            wall_row = (fr.d_residual_d_well_volume * self.height * self.f_wall[wr]
                        if self.hole_volume_change else np.zeros(len(wr)))
            crack = None
            if permeability_derivative and not undrained and np.any(dk_dw > 0):
                crack = self._crack_entries(it.flow, k, dk_dw, act)
            J = assemble_jacobian(
                pattern, blocks=blocks, g_values=g_values,
                gt_values=(rho_dt * self.height * coef)[:, None] * self._g,
                wall_column=self._wall_column, wall_row=wall_row,
                flow_values=fr.jacobian_values, crack=crack)
            # floating DOFs: nodes held only by open contacts (a detached fragment
            # between crack faces; their only stiffness is the 1e-9 regularisation of
            # open contacts). The net fluid force on them (pressure differences between
            # the surrounding cells) has nothing to balance it: hold them for the step,
            # as the mechanics does
            if failed.any():
                kd = J.data[pattern.diag_slots]
                med = _median(kd)
                floating = kd < 1e-6 * med
                if floating.any():
                    hold_rows(J, pattern, floating, med)
                    Ru = np.where(floating, 0.0, Ru)
        elif failed.any():
            # the residual alone: the same floating rows (from the diagonal of K only)
            kd = self._k_diagonal(cs, status, sgn, soft, mech.normal_stiffness(g_n))
            floating = kd < 1e-6 * _median(kd)
            if floating.any():
                Ru = np.where(floating, 0.0, Ru)
        R = np.concatenate([Ru, fr.residual])
        mass_scale = fr.throughput + self._gross_storage(it, old) / dt
        return CoupledResidual(R, J, force_scale, mass_scale, fr, it,
                               (Fn, Fs, status, Un, Us), k, pattern, status)

    def _cluster_memo(self, cs: np.ndarray, failed: np.ndarray) -> tuple:
        """``(coef, G entries -coef g, 1e-4 max |f_c^0| of the failed clusters or None)``
        for the cluster states ``cs``, remembered for the last states asked."""
        key = cs.tobytes()
        if self._cs_memo is None or self._cs_memo[0] != key:
            coef = self.coefficients(cs)
            g_values = -coef[:, None] * self._g
            fc0 = (1e-4 * float(np.max(np.abs(self._fc0[failed]))) if failed.any()
                   else None)
            for a in (coef, g_values):
                a.setflags(write=False)
            self._cs_memo = (key, (coef, g_values, fc0))
        return self._cs_memo[1]

    def _crack_entries(self, flow_state, k, dk_dw, act) -> tuple:
        """``(dR/dk entries, their cells, dk/du)`` of the crack block: ``dk/du = dk/dw_n
        b_n`` of the contact giving the opening."""
        m = self.n_cells
        dkdu = dk_dw[:, None] * self.mechanics.bn_c[np.arange(m), act, :]
        return (self.flow.permeability_derivative_values(flow_state, k),
                self.layout.permeability_cells, dkdu)

    def with_permeability_derivative(self, res: CoupledResidual,
                                     structure: Structure) -> CoupledResidual:
        """``res`` (a drained evaluation with the lagged-permeability Jacobian) with the
        crack block ``dR/dk dk/du`` added to its Jacobian: what
        :meth:`residual_and_jacobian` with ``permeability_derivative=True`` gives at the
        same iterate, without evaluating it again."""
        if res.jacobian is None or res.pattern is None:
            raise InputError("needs a residual with its Jacobian", key="res")
        cs = np.asarray(structure.cluster_state)
        failed = cs != INTACT
        g_n = res.response[3] - np.asarray(structure.ref_normal)
        gap = np.where(failed[:, None], g_n if self.mechanics.closure.nonlinear
                       else np.maximum(g_n, 0.0), 0.0)
        k, dk_dw, _, act = self.crack_permeability(cs, gap, structure.slip)
        if not np.any(dk_dw > 0):
            return res
        J = res.jacobian.copy()
        add_crack_block(J, res.pattern, self._crack_entries(res.state.flow, k, dk_dw, act))
        return replace(res, jacobian=J)

    def _k_diagonal(self, cs, status, sgn, soft, kn) -> np.ndarray:
        """Diagonal of the mechanics tangent on the displacement unknowns (``kn`` the
        contacts' tangent normal stiffness)."""
        mech = self.mechanics
        blocks = mech._tangent_blocks(cs, status, sgn, soft, kn)
        d = np.bincount(mech.dofs.ravel(), weights=np.einsum("cii->ci", blocks).ravel(),
                        minlength=mech.n_dof)
        return d[self.free_dofs]

    def _gross_storage(self, st: CoupledState, old: CoupledState) -> float:
        """Sum of the magnitudes of the separate storage terms of a step [kg]."""
        f = self.flow
        rho_o = f.density_of(old.p)
        dp = st.p - old.p
        comp = f.volumes * rho_o * (f.porosity * f.fluid.compressibility
                                    + f.porosity * f.rock.pore_compressibility) * np.abs(dp)
        skel = rho_o * np.abs(st.flow.extra_pore_volume - old.flow.extra_pore_volume)
        rw = float(f.fluid.rho(old.p_w))
        well = rw * (self.well_storage * abs(st.p_w - old.p_w)
                     + abs(st.flow.well_extra_volume - old.flow.well_extra_volume))
        return float(np.sum(comp) + np.sum(skel) + well)

    # ---------------------------------------------------------------- post-processing
    def volumetric_strain(self, state: CoupledState) -> np.ndarray:
        """Cluster volumetric strain change from the initial state (tension positive)."""
        self._require_init()
        du = np.asarray(state.displacement).reshape(-1) - self.u0
        return (self._g * du[self.mechanics.dofs]).sum(axis=1) / self.mesh.areas

    def stress(self, state: CoupledState) -> np.ndarray:
        """Cluster total stress ``(sxx, syy, sxy)`` [Pa], compression positive.

        Intact clusters: ``sigma = sigma0 - alpha p0 I - C eps(u) + alpha p I`` (the
        mechanics' in-situ state plus the CST/MDEM response; ``u`` from pre-drilling);
        failed clusters: the mechanics' contact-force stress of the state.
        """
        mech = self.mechanics
        u = np.asarray(state.displacement).reshape(-1)[mech.dofs]
        eps = np.einsum("cij,cj->ci", self._B, u)
        iso = np.array([1.0, 1.0, 0.0])
        p0 = mech.in_situ.pore_pressure
        s0 = mech.sigma0 - self.biot * p0 * iso
        s = s0[None, :] - eps @ np.asarray(mech.C).T + self.biot * np.outer(state.p, iso)
        if state.mechanics is not None:
            failed = np.asarray(state.mechanics.cluster_state) != INTACT
            s = np.where(failed[:, None], np.asarray(state.mechanics.stress), s)
        return s
