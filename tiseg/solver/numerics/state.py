"""The operator's state: its fields, slots and ranges, in one object that the operator's
collaborators receive.

Issue 49 replaced the mixins of `tiseg.solver.numerics.operator.TaichiOperator` (four files
sharing ``self``) by collaborators (`ghosts.GhostCells`, `rest.RestRules`,
`finite_volume.FiniteVolume`, `slots.SlotAlgebra`, `split.SplitSweeps`,
`reductions.StepReductions`) that each receive this object and say so in their constructor. It
is the one place that allocates fields, so a field a later feature needs (a bed height, a
member axis on every field) is added here once:

* the compile-time constants of the layout (``nc``, ``NX``, ``gx``, ``is_1d``, the component
  indices ...), which the kernels read through ``ti.static``;
* every field, in one field tree freed with this object: the state slots ``q`` (Taichi compiles
  one kernel per distinct field passed as template, so buffers are slots selected by an
  integer), primitives ``w``, fluxes, slopes, the split sweeps' edges, the parameters ``par``,
  the boundary budgets ``bud``, the rest mask, and the reductions' scratch fields;
* the active and wet x ranges (`ranges.ActiveRange`) and the serial-or-parallel choice;
* the caches that say what the scratch fields hold (``prepared``, ``interior``) and where a
  step stands (``rest_stale``, ``first_stage``, ``mask_inflow``), which every collaborator
  that writes a slot keeps current through `OperatorState.written`.

The run-time numbers (`set_params`, `set_time`) are written here too: they are fields.
"""

import numpy as np
import taichi as ti

from ...taichi_classes import data_oriented

from ... import backend
from ...errors import TisegError
from ...model.physics.param_layout import ParamLayout
from ...model.physics.pointwise import Params, Physics
from ...model.physics.sources import chosen_aux
from ..field_tree import FieldTree
from .bed import bed_with_ghosts
from .gravity import Gravity
from .boundaries import BOUNDARIES
from .config import OperatorConfig
from .ranges import ActiveRange, row_pieces
from .reconstruction import RECONSTRUCTIONS
from .reductions import NSTAB
from .source_terms import SourceTerms

NBUDGET = 4  # mass in through x faces, small mass x, mass y, small mass y

# A launch's numbers per member in a batch (members > 1), a row of OperatorState.coef each:
# the coefficients of a combination's terms (or a sweep's lambda and dt, a viscous stage's
# mu, nu, mu~ dt, gamma~ dt) from column 0, the friction projection's time, the slot the
# member's result goes to, whether the member takes part, whether its viscous stage is its
# last. A single run passes them as the kernels' arguments instead.
C_TAU, C_DST, C_LIVE, C_FINAL = 6, 7, 8, 9
NCOEF = 10


@data_oriented
class OperatorState:
    def __init__(self, cfg: OperatorConfig, nslots: int, serial: bool | None, members: int = 1):
        """The constants and fields of ``cfg``'s layout with ``nslots`` state slots for each of
        ``members`` ensemble members; the field tree is finalised by `finalize` (the operator
        calls it once its collaborators are built). ``serial``: see `TaichiOperator`."""
        st = backend.state()
        self.generation = st.generation
        self.cfg = cfg
        lay = cfg.layout
        self.lay = lay
        self.nslots = nslots
        if not (isinstance(members, int) and members >= 1):
            raise TisegError(f"members={members!r}: give a whole number >= 1")
        # the ensemble members: every field of the state, the parameters and the reductions
        # have a member axis of this size, and one launch covers them all. The cells' fields
        # hold the members innermost, (..., NX, NY, M), as the loops run over them: the
        # members of a cell lie side by side (contiguous on a CPU, coalesced on a GPU), and
        # one member compiles to the fields and loops of a single run
        self.M = M = members
        self.fp = ti.f64 if st.precision == "f64" else ti.f32
        self.np_fp = np.float64 if st.precision == "f64" else np.float32
        nc, NX, NY = lay.nc, lay.NX, lay.NY
        # compile-time constants
        self.nc, self.NX, self.NY = nc, NX, NY
        self.nx, self.ny, self.gx, self.gy = lay.nx, lay.ny, lay.gx, lay.gy
        self.is_1d, self.seg, self.visc = lay.is_1d, lay.segregation, cfg.viscous
        self.H, self.HU, self.HV, self.HPHI = lay.H, lay.HU, lay.HV, lay.HPHI
        # first order: no slopes (tiseg.solver.numerics.reconstruction)
        self.rec_first = not RECONSTRUCTIONS[cfg.reconstruction].slopes
        self.local_rate = bool(cfg.local_step_rate) and not self.is_1d
        # the split scheme (numerics.stepper "hancock", tiseg.solver.numerics.split): sweeps
        # instead of evaluations of L, with their own edge fields and no stored slopes
        self.split = bool(cfg.split)
        self.bc = tuple(cfg.bc)
        self.bcs = tuple(BOUNDARIES[b] for b in cfg.bc)  # x_lo, x_hi, y_lo, y_hi
        # fields: only what this scene needs (no y slopes/fluxes in 1D, nc follows the
        # effects), in one field tree that is freed with this object; a field the scene does
        # not need is not an attribute (fy, sy, ew, ee, drain) or None (the others)
        ft = self.field_tree = FieldTree()
        self.q = ft.vector(nc, self.fp, (nslots, NX, NY, M))
        self.w = ft.vector(nc, self.fp, (NX, NY, M))
        self.fx = ft.vector(nc, self.fp, (NX, NY, M))
        slopes = not self.rec_first and not self.split
        self.sx = ft.vector(nc, self.fp, (NX, NY, M)) if slopes else None
        if not self.is_1d:
            self.fy = ft.vector(nc, self.fp, (NX, NY, M))
            self.sy = ft.vector(nc, self.fp, (NX, NY, M)) if slopes else None
        if self.split:  # a sweep's predicted edge states and draining factors
            self.ew = ft.vector(nc, self.fp, (NX, NY, M))
            self.ee = ft.vector(nc, self.fp, (NX, NY, M))
            self.drain = ft.field(self.fp, (NX, NY, M))
        # where each component's numbers sit in par, built once from the components
        self.params = ParamLayout.of(cfg)
        self.par = ft.field(self.fp, (M, self.params.end))
        # the auxiliary fields the scene's source terms read (a vector per cell), and the
        # split x sweep's source rates of the step (predicted once, applied in the update):
        # only with terms (tiseg.model.physics.sources)
        n_aux = len(chosen_aux(cfg.sources))
        self.aux = ft.vector(n_aux, self.fp, (NX, NY, M)) if n_aux else None
        self.srate = ft.vector(nc, self.fp, (NX, NY, M)) if self.split and cfg.sources else None
        # a bed (tiseg.solver.numerics.bed): its heights on every cell, and the two pressure
        # corrections of each x and y face (the low side's, the high side's); in the split
        # sweeps also the bed at each cell's predicted edges (low, high)
        self.bed = ft.field(self.fp, (NX, NY)) if cfg.bed else None
        self.pcx = ft.vector(2, self.fp, (NX, NY, M)) if cfg.bed else None
        self.pcy = ft.vector(2, self.fp, (NX, NY, M)) if cfg.bed and not self.is_1d else None
        self.eb = ft.vector(2, self.fp, (NX, NY, M)) if cfg.bed and self.split else None
        # the unsplit scheme's slopes of eta = h + b along x and y, taken with the slopes of w
        # and read by both faces and the centred source of a cell (none at first order)
        stored = cfg.bed and not self.split and not self.rec_first
        self.es = ft.vector(2, self.fp, (NX, NY, M)) if stored else None
        # solid cells, whose faces are walls (tiseg.solver.numerics.walls): 1 where solid
        self.solid = ft.field(ti.i8, (NX, NY)) if cfg.solid else None
        # inflow concentration per cross-slope cell: only with an inflow that carries phi
        self.inflow_prof = (
            ft.field(self.fp, (M, NY)) if self.seg and cfg.bc[0] == "inflow" else None
        )
        # Active range [a, b) of x indices whose cells may change, the wet scan's range and
        # the serial-or-parallel choice (tiseg.solver.numerics.ranges); its fields, which the
        # kernels read, under their old names. Serial loops: forced (True/False), or chosen
        # from the cells a launch covers, for the active range when the range is set.
        threads = st.threads or backend.available_cores()
        self.ranges = ActiveRange(ft, lay, serial, threads, st.arch == "cpu", M)
        # loops over a strip of cells (ghost columns and rows: a few thousand cells) run on
        # one CPU thread, where a hand-off costs more than the work; on a GPU one thread
        # would walk the strip alone (1 ms a launch at 750 cells/m on an H200, most of a
        # step), so there they run in parallel. Each iteration writes its own cells: the
        # same bits.
        self.strip_serial = st.arch == "cpu"
        self.act, self.wet, self.wrng = self.ranges.act, self.ranges.wet, self.ranges.wrng
        # rows reduced by one thread before one atomic (_stability, _wet_extent): a row in
        # 2D, 256 cells in 1D (one row of NX cells), where per-cell atomics would contend
        self.rows_per_block = max(1, 256 // NY)
        # ... and each row cut into this many pieces along y, reduced one by one: Taichi's
        # CPU backend hands a parallel loop to its threads in equal chunks of at least 512
        # iterations, so a loop over the ~500 rows of a fingers run's active range ran on
        # one thread; the pieces give the smallest range that runs in parallel
        # (SERIAL_CELLS cells) 512 iterations per thread. On a GPU, many threads.
        self.row_pieces = row_pieces(lay, threads, st.arch == "cpu")
        # Boundary budgets per slot: rates of (mass, small-particle mass) entering through
        # the x faces and the y faces. A combination of slots applies the same linear
        # combination to them as to the states, so slot 0 accumulates exactly the time
        # integral the scheme uses. (row nslots: the boundary rates of a fused stage, whose
        # rate has no slot)
        self.bud = ft.field(self.fp, (M, nslots + 1, NBUDGET))
        # a batch's numbers per member and launch (C_TAU ...), and which members still run
        # (1; 0: finished or stopped, their state no longer written): one field write a launch
        # instead of one per member
        self.batched = M > 1
        self.coef = ft.field(self.fp, (M, NCOEF)) if self.batched else None
        self.running = ft.field(ti.i32, M) if self.batched else None
        self.phys = Physics(cfg, self.par, self.params)
        # gravity per x column on a run-out's bend (tiseg.solver.numerics.gravity); on a
        # plane no field, the two numbers of par
        self.grav = Gravity(self, ft)
        self.terms = SourceTerms(self)  # the source terms beyond (6.4), if any
        # With the projected friction: which cells were at rest at the start of the step,
        # the state in slot 0 (RestRules.rest_face). Recomputed at the first preparation
        # after slot 0 is written, so every stage of a step sees the same rest faces.
        self.rest = ft.field(ti.i8, (NX, NY, M)) if self.phys.fr_projected else None
        # the split step's friction acts once, after its last sweep, at the speed of the
        # step's initial state (SplitSweeps.sweep): in 2D that speed is kept from the first
        # sweep (in 1D as well when a viscous sub-step may open the step)
        spd = self.split and self.phys.fr_projected and (not self.is_1d or self.visc)
        self.spd0 = ft.field(self.fp, (NX, NY, M)) if spd else None
        # and the thickness the x sweep's gravity acted on, for the friction of a 2D step
        # whose last sweep is along y (SplitSweeps._sweep_update)
        hg = self.split and self.phys.fr_projected and not self.is_1d
        self.hg = ft.field(self.fp, (NX, NY, M)) if hg else None
        # the reductions' numbers (tiseg.solver.numerics.reductions): step_rule "local"'s
        # per-cell speeds, the reduced stability numbers, the row sums of the totals
        self.spd = ft.vector(2, self.fp, (NX, NY, M)) if self.local_rate else None
        self.red = ft.field(self.fp, (M, NSTAB))
        self.rowsum = ft.field(ti.f64, (M, NX, 2))
        self.total = ft.field(ti.f64, (M, 2))
        # A law with hysteresis holds resting cells exactly for a whole step (HELD): columns
        # of such cells far from any moving one then need no work at all, and the active
        # range leaves them out (RestRules._quiescent, Simulation._set_active). Decided from
        # the rest mask of the step before, so the mask is part of the run's state
        # (checkpoints keep it). Settable until the first step compiles the wet scan.
        self.skip_rest = bool(self.phys.fr_projected and self.phys.law.hysteresis)
        # the caches
        self.prepared = None  # (slot, t, active range) whose primitives are in w
        # (slot, active range) whose interior primitives a limited combine left in w (ghost
        # cells and slopes still to do)
        self.interior = None
        self.rest_stale = True  # slot 0 was written: the next preparation takes the mask
        self.first_stage = False  # the next limited combination is a step's first stage
        self.mask_inflow = None  # whether an inflow ran when the mask was taken (None: none)
        # each member's run-time configuration (set_params; the compiled options are cfg's)
        self.cfgs = [cfg] * self.M
        # the (h, on) of the inflow last written into each member's row of par
        self.inflow_key = [None] * self.M
        # host copies of the per-member rows that set_params writes whole
        self._par_host = np.zeros((self.M, self.params.end), dtype=self.np_fp)
        self._prof_host = np.zeros((self.M, NY)) if self.inflow_prof is not None else None
        self._running = None  # the running flags last written (set_running)
        self._observers = {}  # the run's observers of every member (observer)
        # how often the slots or budgets changed as a whole (set, reset_budget, a batch's
        # step): what an observer read of them at another count is stale (`changed`)
        self.changes = 0

    def finalize(self) -> None:
        """The fields exist from here on; they are freed with this object."""
        self.field_tree.finalize()
        self.field_tree.free_with(self)

    # ------------------------------------------------------------------ run-time numbers
    def set_params(self, cfg: OperatorConfig, member: int | None = None) -> None:
        """Copy run-time numbers into the parameter field (no recompilation): into member
        ``member``'s row, or every member's (None). ``cfg`` must have the compiled options
        this state was built for; its run-time numbers may differ from member to member."""
        p = ParamLayout.of(cfg).vector(cfg)  # the common slots, then the components'
        rows = range(self.M) if member is None else (self._member(member),)
        for e in rows:
            self.cfgs[e] = cfg
        self.cfg = self.cfgs[0]
        self.prepared = self.interior = None
        self.rest_stale = True
        # a new h_min may make films outside the active range wet (the range is set before
        # the first call, in TaichiOperator.__init__), and new numbers may start resting cells
        self.set_active(self.gx, self.gx + self.nx)
        self.forget_rest()
        self._par_host[list(rows)] = p.astype(self.np_fp)
        self.par.from_numpy(self._par_host)
        self.grav.fill(self.cfgs)
        self.terms.fill_aux(self.cfgs)
        if self.inflow_prof is not None:
            # the inflow concentration profile (6.9) + noise, computed once on the host: no
            # 64-bit transcendental functions in the kernels (SPIR-V has none), and the same
            # numbers as the NumPy reference
            y = (np.arange(self.ny) + 0.5) * cfg.dy
            for e in rows:
                self._prof_host[e, self.gy : self.gy + self.ny] = cfg.inflow_phi_profile(y)
            self.inflow_prof.from_numpy(self._prof_host.astype(self.np_fp))
        self.inflow_key = [None] * self.M

    def observer(self, cls):
        """This state's one instance of ``cls``, a run-side class that reads the state on
        the device for each member (peak fields, guard: `tiseg.run.peaks`,
        `tiseg.run.guards`), made with ``cls(self)`` on first use: every member of a batch
        uses it with its own index, so its kernels are traced and compiled once, not once a
        member. It lives as long as this state."""
        if cls not in self._observers:
            self._observers[cls] = cls(self)
        return self._observers[cls]

    def changed(self) -> None:
        """The slots or budgets changed (a host write, a batch's step): the totals, budgets
        and guard scans a batch's observers took before are stale."""
        self.changes += 1

    def _before_host_write(self) -> None:
        """Let the observers finish what they hold of the state before the host replaces
        it (the guard's deferred copies of a batch's last good states)."""
        for obs in self._observers.values():
            hook = getattr(obs, "before_host_write", None)
            if hook is not None:
                hook()

    def _member(self, member: int) -> int:
        if not (isinstance(member, (int, np.integer)) and 0 <= member < self.M):
            raise TisegError(f"member {member!r}: this state has members 0 to {self.M - 1}")
        return int(member)

    def set_bed(self, b=None, solid=None) -> None:
        """The bed heights (nx, ny) [m] normal to the reference plane and the solid cells
        (nx, ny) bool, each where the operator was built for it; ghost cells from the
        boundaries (`bed.bed_with_ghosts`)."""
        for name, given, field in (("a bed", b, self.bed), ("solid cells", solid, self.solid)):
            if given is not None and field is None:
                raise TisegError(f"set_bed: the operator was built without {name}")
        if b is not None:
            self.bed.from_numpy(bed_with_ghosts(b, self.lay, self.bc).astype(self.np_fp))
        if solid is not None:
            mask = bed_with_ghosts(np.asarray(solid, dtype=float), self.lay, self.bc) > 0.5
            self.solid.from_numpy(mask.astype(np.int8))
        self.prepared = self.interior = None
        self.rest_stale = True

    def set_time(self, t) -> None:
        """Inflow thickness of (6.8) at the stage time t (ramp) and whether it still flows,
        each member's from its own numbers; ``t``: one time, or one per member (a batch's
        members each at their own time)."""
        if self.bc[0] != "inflow":
            return
        keys = []
        for te, cfg in zip(self.times(t), self.cfgs):
            h, _, _ = cfg.inflow_state(te)
            keys.append((h, 0.0 if te > cfg.inflow_stop else 1.0))
        if keys != self.inflow_key:  # (the ramp, the stop) every member's row in one launch
            vals = np.array(keys, dtype=self.np_fp)
            self._inflow_in(np.ascontiguousarray(vals[:, 0]), np.ascontiguousarray(vals[:, 1]))
            self.inflow_key = keys

    @ti.kernel
    def _inflow_in(self, h: ti.types.ndarray(), on: ti.types.ndarray()):
        """Each member's inflow thickness and on/off flag into its parameter row."""
        ti.loop_config(serialize=True)
        for e in range(self.M):
            self.par[e, Params.IN_H] = h[e]
            self.par[e, Params.IN_ON] = on[e]

    def inflow_on(self, t) -> bool:
        """Whether an inflow runs at time t (until the scene's inflow stop time) in any
        member (t: one time, or one per member)."""
        return self.bc[0] == "inflow" and any(
            not te > c.inflow_stop for te, c in zip(self.times(t), self.cfgs)
        )

    def times(self, t) -> tuple:
        """Each member's time of a launch at ``t`` (one time for all, or one per member of a
        batch); also the launch's key in the caches of what w holds."""
        if not self.batched or np.ndim(t) == 0:
            return (t,) * self.M
        return tuple(float(v) for v in t)

    # ------------------------------------------------------------------ host access
    def check_alive(self) -> None:
        if backend.state().generation != self.generation:
            raise TisegError(
                "Taichi was re-initialised (tiseg.init with other settings); "
                "this simulation's fields no longer exist: create it again"
            )

    def get(self, slot: int = 0, member: int = 0) -> np.ndarray:
        """Slot of member ``member`` as a float64 array shaped (nc, NX, NY): one slot of one
        member copied out (a batch's other members and slots stay on the device)."""
        out = np.empty((self.nc, self.NX, self.NY), dtype=self.np_fp)
        self._slot_out(self._member(member), int(slot), out, self.serial_loops(whole=True))
        return out.astype(np.float64)

    def set(self, slot: int, arr: np.ndarray, member: int | None = None) -> None:
        """Replace slot ``slot`` of member ``member`` (of every member: None) by ``arr``
        shaped (nc, NX, NY)."""
        self._before_host_write()
        self.prepared = self.interior = None
        self.rest_stale = self.rest_stale or slot == 0
        self.set_active(self.gx, self.gx + self.nx)  # wet cells may now lie anywhere
        if slot == 0:
            self.forget_rest()  # and any of them may move
        a = np.ascontiguousarray(np.asarray(arr), dtype=self.np_fp)
        if a.shape != (self.nc, self.NX, self.NY):
            raise TisegError(
                f"set: a state of shape {a.shape}, expected {(self.nc, self.NX, self.NY)}"
            )
        rows = range(self.M) if member is None else (self._member(member),)
        for e in rows:
            self._slot_in(e, int(slot), a, self.serial_loops(whole=True))
        self.changed()

    @ti.kernel
    def _slot_out(self, e: ti.i32, s: ti.i32, out: ti.types.ndarray(), serial: ti.template()):
        """out[c, i, j] := component c of slot s of member e, every cell."""
        ti.loop_config(serialize=serial)
        for i, j in ti.ndrange(self.NX, self.NY):
            v = self.q[s, i, j, e]
            for c in ti.static(range(self.nc)):
                out[c, i, j] = v[c]

    @ti.kernel
    def _slot_in(self, e: ti.i32, s: ti.i32, a: ti.types.ndarray(), serial: ti.template()):
        """Slot s of member e := a (nc, NX, NY), every cell."""
        ti.loop_config(serialize=serial)
        for i, j in ti.ndrange(self.NX, self.NY):
            v = self.q[s, i, j, e]
            for c in ti.static(range(self.nc)):
                v[c] = a[c, i, j]
            self.q[s, i, j, e] = v

    def budget(self, slot: int = 0, member: int = 0) -> np.ndarray:
        """Accumulated [mass, small mass] that entered through x faces and y faces [m^3]."""
        return self.bud.to_numpy()[self._member(member), slot].astype(float)

    def reset_budget(self, values=None, member: int | None = None) -> None:
        """Slot 0's budget of member ``member`` (every member's: None) set to ``values``
        (zero: None)."""
        self._before_host_write()
        b = self.bud.to_numpy()
        rows = slice(None) if member is None else self._member(member)
        b[rows, 0] = 0.0 if values is None else values
        self.bud.from_numpy(b)
        self.changed()

    # ------------------------------------------------------------------ the caches
    def written(self, dst: int, primitives: bool = False) -> None:
        """Slot dst changed; with ``primitives`` its interior primitives are now in w."""
        if dst == 0:
            self.rest_stale = True
        if primitives:
            self.prepared = None
            self.interior = (dst, self.active)
            return
        if self.prepared is not None and self.prepared[0] == dst:
            self.prepared = None
        if self.interior is not None and self.interior[0] == dst:
            self.interior = None

    def written_by(self, dst, live, primitives: bool) -> None:
        """`written` after a launch whose members write ``dst`` (one slot, or one per member of
        a batch), those of ``live`` only (None: all). Where they write different slots, or
        some write none, w holds no one slot's primitives."""
        if not self.batched:
            self.written(dst, primitives=primitives)
            return
        dsts = set(np.atleast_1d(np.asarray(dst, dtype=int)).tolist())
        if len(dsts) == 1 and (live is None or bool(np.all(live))):
            self.written(dsts.pop(), primitives=primitives)
            return
        for d in dsts:
            self.written(d)
        self.prepared = self.interior = None

    def fresh(self, slot: int, t: float) -> int:
        """What the last preparation left valid in w for ``slot`` at time t: 2 everything
        (the slot prepared at t), 1 the interior (a limited combine's or sweep's result, or
        the slot prepared at another time), 0 nothing."""
        key = (slot, self.times(t), self.active)
        interior = self.interior == (slot, self.active) or (
            self.prepared is not None and self.prepared[::2] == key[::2]
        )
        return 2 if self.prepared == key else (1 if interior else 0)

    def first_of_step(self, limit: bool) -> bool:
        """Whether this limited combination is the step's first stage, where a law with
        hysteresis decides which resting cells the static friction holds
        (RestRules.project): the first one after the rest mask was computed for a new
        step."""
        first = bool(limit) and self.first_stage and self.phys.law.hysteresis
        if limit:
            self.first_stage = False
        return first

    def forget_rest(self) -> None:
        """Clear the rest mask: every cell counts as live until a step has marked it again."""
        if self.rest is not None:
            self.rest.fill(0)
        self.mask_inflow = None

    # ------------------------------------------------------------------ a batch's numbers
    def per_member(self, v) -> np.ndarray:
        """``v`` (a number, or one per member) as an array of the members' values."""
        a = np.asarray(v, dtype=np.float64)
        if a.ndim == 0:
            return np.full(self.M, float(a))
        if a.shape != (self.M,):
            raise TisegError(f"{a.shape[0]} values given for {self.M} members")
        return a

    def put_numbers(self, columns: dict[int, object]) -> None:
        """A batch's numbers of the next launch, {column: value or one per member} (columns
        not given are 0, C_LIVE 1): one field write."""
        rows = np.zeros((self.M, NCOEF))
        rows[:, C_LIVE] = 1.0
        for k, v in columns.items():
            rows[:, k] = self.per_member(v)
        self._put_numbers(rows.astype(self.np_fp))  # (a launch: from_numpy costs ~1 ms)

    @ti.kernel
    def _put_numbers(self, rows: ti.types.ndarray()):
        ti.loop_config(serialize=True)  # (a few hundred numbers)
        for e, k in ti.ndrange(self.M, NCOEF):
            self.coef[e, k] = rows[e, k]

    def set_running(self, running) -> None:
        """Which members a batch still advances (one bool per member): the others' states
        are no longer written (their ghost cells neither)."""
        flags = np.asarray(running, dtype=bool)
        if flags.shape != (self.M,):
            raise TisegError(f"{flags.shape} running flags given for {self.M} members")
        if self._running is None or not np.array_equal(flags, self._running):
            self.running.from_numpy(flags.astype(np.int32))
            self._running = flags.copy()

    @ti.func
    def number(self, e, k: ti.template(), arg):
        """Member e's number k of this launch: the launch's argument ``arg`` in a single run,
        its row of ``coef`` in a batch."""
        r = arg
        if ti.static(self.batched):
            r = self.coef[e, k]
        return r

    @ti.func
    def numbers(self, e, args):
        """The vector of member e's first numbers of this launch (``args`` in a single run)."""
        r = args
        if ti.static(self.batched):
            for k in ti.static(range(args.n)):
                r[k] = self.coef[e, k]
        return r

    @ti.func
    def dst(self, e, arg):
        """The slot member e's result of this launch goes to (``arg`` in a single run)."""
        r = arg
        if ti.static(self.batched):
            r = ti.cast(self.coef[e, C_DST], ti.i32)
        return r

    @ti.func
    def live(self, e):
        """Whether member e takes part in this launch's update: always in a single run; in a
        batch where it still runs and this launch is one of its stages."""
        r = True
        if ti.static(self.batched):
            r = self.running[e] != 0 and self.coef[e, C_LIVE] > 0.5
        return r

    @ti.func
    def runs(self, e):
        """Whether member e's state may be written (ghost cells): a batch's finished and
        stopped members' may not."""
        r = True
        if ti.static(self.batched):
            r = self.running[e] != 0
        return r

    # ------------------------------------------------------------------ ranges
    def set_active(self, a: int, b: int, wet: tuple[int, int] | None = None) -> None:
        """Restrict the operator to interior x indices [a, b) (array indices, ghosts counted).
        ``wet``: the range [wa, wb) the next wet scan covers, which holds [a, b); by default
        [a, b) itself. It is wider where resting regions are left out (ActiveRange.set)."""
        if not self.ranges.set(a, b, wet):
            return  # each field write from Python is a kernel launch
        self.prepared = self.interior = None
        if self.rest is not None and self.first_stage:
            # the step's rest mask was taken on the old range (RestRules.mark: act +- 4) and the
            # step has not begun: take it again on the new one (slot 0 is the same), or
            # cells the range now takes in would keep bits of an earlier step, or none
            self.rest_stale = True

    @property
    def active(self) -> tuple[int, int]:
        """The active x range [a, b) (ActiveRange)."""
        return self.ranges.active

    @property
    def wet_range(self) -> tuple[int, int]:
        """The x range [wa, wb) the next wet scan covers (ActiveRange)."""
        return self.ranges.wet_range

    @property
    def force_serial(self) -> bool | None:
        return self.ranges.force_serial

    def serial_loops(self, whole: bool = False) -> bool:
        """Whether the next launch runs its loops on one thread (ActiveRange.serial_loops):
        both modes give the same bits (tests/test_determinism.py)."""
        return self.ranges.serial_loops(whole)
