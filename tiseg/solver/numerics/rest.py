"""The projected friction's rest machinery (``numerics.friction_scheme = "projected"``).

Shallow-water codes that bring material to rest apply friction as a projection after the
explicit update (Mangeney et al., Bouchut et al.): if the friction impulse can cancel the
momentum, the cell stops exactly; otherwise the momentum shrinks along its direction. Around
that projection (`tiseg.model.physics.pointwise.Physics`) this module keeps a deposit at rest
bitwise:

* the rest mask of a step's start (``rest``: REST where u = v = 0, else the signs of u and v;
  HELD where a law with hysteresis holds the cell for the whole step; WET where h >= h_min),
  `RestRules.mark`;
* the face rules (`RestRules.rest_face`): no mass between two cells at rest, and at least
  the upwind cell's outrunning flux where it moves into a slower neighbour; and a face next
  to a cell that was wet or moving at the step's start keeps its flux through all the
  step's stages (`RestRules.live_at_start`);
* the projection of a limited stage (`RestRules.project`) and the exact rest of
  `RestRules.keep_rest`;
* the skipping of quiescent regions (`RestRules._quiescent`, the wet scan
  `RestRules.wet_extent`) and the mask as part of a checkpoint (`RestRules.rest_state`).

A collaborator of `tiseg.solver.numerics.operator.TaichiOperator` that receives the operator's
state (`state.OperatorState`, which holds the rest mask ``rest`` and the caches that say where
a step stands) and its ghost cells (`ghosts.GhostCells`, which the wet scan fills first); the
evaluation of L (`finite_volume.FiniteVolume`), the slot algebra and the split sweeps call its
Taichi functions.
"""

import numpy as np
import taichi as ti

from ...taichi_classes import data_oriented

from ...model.physics.params import Params
from .ranges import piece_at, piece_count

# bits of the rest mask (projected friction), set at a step's start (mark, project)
REST = 1  # u = v = 0 exactly
HELD = 2  # the static friction holds the cell for the whole step (laws with hysteresis)
X_POS, X_NEG, Y_POS, Y_NEG = 4, 8, 16, 32  # moving with u > 0, u < 0, v > 0, v < 0
WET = 64  # h >= h_min (a face next to it carries a flux for the whole step: live_at_start)


@data_oriented
class RestRules:
    def __init__(self, state, ghosts):
        """``state``: the operator's fields, slots and ranges (`state.OperatorState`, whose
        rest mask ``rest`` these rules take and read); ``ghosts``: its ghost cells, which the
        wet scan fills first (`ghosts.GhostCells`)."""
        self.state = state
        self.ghosts = ghosts

    @ti.func
    def mark(self, serial: ti.template()):
        """rest := REST where the prepared primitives have u = v = 0, else the signs of u and v
        (X_POS / X_NEG, Y_POS / Y_NEG), and WET where h >= h_min, on the cells the faces near
        the active range read (further out no face flux is computed). With a law with
        hysteresis the step's first stage then adds HELD to the cells the static friction
        holds (project)."""
        lo = ti.max(self.state.act[0] - 4, 0)
        hi = ti.min(self.state.act[1] + 4, self.state.NX)
        ti.loop_config(serialize=serial)
        for i, j, e in ti.ndrange((lo, hi), (0, self.state.NY), self.state.M):
            hmin = self.state.par[e, Params.H_MIN]
            w = self.state.w[i, j, e]
            r = w[1] == 0.0
            if ti.static(not self.state.is_1d):
                r = r and w[self.state.HV] == 0.0
            flag = 0
            if r:
                flag = REST
            else:
                if w[1] > 0.0:
                    flag |= X_POS
                elif w[1] < 0.0:
                    flag |= X_NEG
                if ti.static(not self.state.is_1d):
                    if w[self.state.HV] > 0.0:
                        flag |= Y_POS
                    elif w[self.state.HV] < 0.0:
                        flag |= Y_NEG
            if w[0] >= hmin:
                flag |= WET
            if ti.static(self.state.bcs[0].prescribed):
                flag = self._inlet_moves(e, flag, i, j)
            self.state.rest[i, j, e] = ti.cast(flag, ti.i8)

    @ti.func
    def _inlet_moves(self, e, flag, i, j):
        """A running inflow's ghost cells move downslope (X_POS), whatever thickness its ramp
        (6.8) starts the step with: at h_in = 0 they had u = 0 and counted as at rest, so the
        inlet face of a step starting then carried no mass for the whole step, though the
        ghosts hold the inflow of the step's middle (the first step of every run with a
        ramped inflow admitted nothing, and a one-step run nothing at all)."""
        out = flag
        lo, hi = ti.static(self._inlet_row_range())
        if i < self.state.gx and lo <= j < hi:
            if self.state.par[e, Params.IN_ON] > 0.5 and self.state.par[e, Params.IN_U] > 0.0:
                out = (flag & ~REST) | X_POS
        return out

    def _inlet_row_range(self) -> tuple[int, int]:
        """The array rows [lo, hi) of the inlet's ghost cells (inflow.width, inflow.y0)."""
        rows = self.state.cfg.inflow_rows
        lo, hi = (0, self.state.ny) if rows is None else rows
        return self.state.gy + lo, self.state.gy + hi

    @ti.func
    def wet_at_start(self, e, i0, j0, i1, j1):
        """Whether cell (i0, j0) or (i1, j1) was wet (h >= h_min) at the step's start: their
        face then carries its flux in every stage of the step, even where both cells have
        thinned below h_min since (face_wet), so that the step's rates are one smooth
        function, as for the rest rules (rest_face). Switched off mid-step, the face's flux
        stayed in the rate of the step's start only, which RKC's last stage weighs with a
        negative coefficient (about -1.6 dt at 2 stages): a thin cell fed through that face
        was emptied below zero, and the stage limiter's clip to h = 0 then created mass (a
        relative 1e-6 in one step at the margin of a flow spreading from a narrow inlet, the
        levees scene at 150 cells/m). A face that becomes wet mid-step switches on as before."""
        r = ti.cast(self.state.rest[i0, j0, e], ti.i32) | ti.cast(
            self.state.rest[i1, j1, e], ti.i32
        )
        return (r & WET) != 0

    @ti.func
    def live_at_start(self, e, i0, j0, i1, j1):
        """wet_at_start, or one of the two cells moved at the step's start (a film with a
        velocity, the split sweeps, whose films flow): the face then carries its flux in every
        stage of the step even where both cells are films now (face_wet). Between two films
        at rest no mass moves: a dry bed stays dry, and the film a flow leaves behind stays
        where the friction stopped it."""
        r = ti.cast(self.state.rest[i0, j0, e], ti.i32) & ti.cast(
            self.state.rest[i1, j1, e], ti.i32
        )
        return self.wet_at_start(e, i0, j0, i1, j1) or (r & REST) == 0

    @ti.func
    def rest_face(self, e, F, wl, wr, d: ti.template(), i0, j0, i1, j1):
        """With the projected friction scheme, the mass (and h phi) flux at a face next to a
        cell at rest. "At rest" is read from the step's initial state (mark), not from
        the stage's: a cell that the first stage stops must not switch its faces off for the
        later ones. The rates of a step are then one smooth function, which RKC's stage
        weights (of both signs, ~2 and -1.6 at 2 stages) rely on; switching mid-step emptied a
        thin cell next to a deposit below zero, and the limiter's clip then created mass.

        * Between two cells at rest no mass crosses: the central schemes' dissipation
          a/2 (h_r - h_l) would otherwise let a deposit's surface relax for ever. The
          momentum flux stays (the pressure), and the friction projection decides whether
          the cells start to move.
        * Where the upwind cell moves towards its neighbour (u_n > 0 on the left, or < 0 on
          the right, at the step's start) and the neighbour does not move against it, at
          least F_h >= f_u - f_d^2 / f_u crosses, f_u = h_l max(u_l, 0) the upwind cell's own
          flux and f_d = h_r max(u_r, 0) the downwind cell's the same way (edge states;
          mirrored for a right-hand upwind cell), with h phi carried at the upwind cell's
          phi. Into a cell at rest that is the upwind cell's whole flux; between cells of the
          same flux it is zero; into a slow cell it falls short of f_u by f_d^2 / f_u only.
          The central flux's dissipation a/2 (h_r - h_l), which at low Froude numbers is
          most of its mass flux, would
          otherwise draw mass back out of a thicker, slower or resting neighbour against the
          flow: thin films flowing into a deposit, and short chains of slow cells, were held
          in place by it and kept a speed of mm/s for ever while no mass moved. In a flow
          whose flux does not collapse from one cell to the next the bound lies below the
          central flux and changes nothing; the momentum flux stays the central one."""
        out = F
        if ti.static(self.state.phys.fr_projected):
            r0 = ti.cast(self.state.rest[i0, j0, e], ti.i32)
            r1 = ti.cast(self.state.rest[i1, j1, e], ti.i32)
            if (r0 & REST) != 0 and (r1 & REST) != 0:
                out[0] = 0.0
                if ti.static(self.state.seg):
                    out[self.state.HPHI] = 0.0
            else:
                # at least the flux by which the upwind cell outruns its neighbour
                pos = ti.static(X_POS if d == 0 else Y_POS)
                neg = ti.static(X_NEG if d == 0 else Y_NEG)
                if (r0 & pos) != 0 and (r1 & neg) == 0:
                    out = self._flux_floor(e, out, wl, wr, d, 1.0)
                elif (r1 & neg) != 0 and (r0 & pos) == 0:
                    out = self._flux_floor(e, out, wr, wl, d, -1.0)
        return out

    @ti.func
    def film_faces(self, e, Fm, Fp, i, j, im, jm, ip, jp):
        """The fluxes through the low (Fm) and high (Fp) face of cell (i, j) along one
        direction as that cell takes them: a film (thinner than h_min) at rest at the step's
        start takes no momentum through a face to a neighbour at rest. No mass crosses such a
        face (rest_face), but its momentum flux, the pressure of the neighbour, stays for the
        neighbour's friction hold to see; a film, with next to no mass to carry it, was given
        speeds of km/s by it. The neighbour still feels it (the cells' friction projections
        already take momentum out of the books)."""
        r = ti.cast(self.state.rest[i, j, e], ti.i32)
        if (r & REST) != 0 and (r & WET) == 0:
            if (ti.cast(self.state.rest[im, jm, e], ti.i32) & REST) != 0:
                Fm = self.still(Fm)
            if (ti.cast(self.state.rest[ip, jp, e], ti.i32) & REST) != 0:
                Fp = self.still(Fp)
        return Fm, Fp

    @ti.func
    def still(self, F):
        """F (a flux, or a primitive state) with its momentum (or velocity) components zero."""
        out = F
        out[1] = 0.0
        if ti.static(not self.state.is_1d):
            out[self.state.HV] = 0.0
        return out

    @ti.func
    def _flux_floor(self, e, F, wu, wd, d: ti.template(), s: ti.template()):
        """F with its mass flux raised (s = 1, upwind cell on the left) or lowered (s = -1, on
        the right) to s (f_u - f_d^2 / f_u) where that is beyond it: f_u = h max(s u_n, 0) of
        the upwind edge state wu, f_d the same of the downwind one wd; h phi then moves at
        the upwind cell's phi (rest_face)."""
        out = F
        c = ti.static(1 if d == 0 else self.state.HV)
        fu = wu[0] * ti.max(s * wu[c], 0.0)
        fd = wd[0] * ti.max(s * wd[c], 0.0)
        # f_u - f_d^2 / f_u > s F  <=>  f_u^2 - f_d^2 > s F f_u (f_u > 0): the division only
        # where the floor applies, which in a flow is rare (a division on every face cost ~2 %)
        if fu > 0.0 and fu * fu - fd * fd > s * out[0] * fu:
            b = s * (fu - fd * fd / fu)
            if s * b > s * out[0]:  # never false but at a tie of rounding
                out[0] = b
                if ti.static(self.state.seg):
                    out[self.state.HPHI] = b * self.state.phys.transported(e, wu[self.state.HPHI])
        return out

    @ti.func
    def project(self, e, acc, tau, i, j, first: ti.template(), spd0, hb):
        """The friction projection of a stage's result (Physics.project_friction, with the
        coefficient at ``spd0``, the speed of the state the stage started from, and the
        impulse on the thickness ``hb``). With a law
        with hysteresis the static friction decides once per step, on its first stage, which
        of the cells at rest at the step's start it holds (Physics.holds, marked HELD in rest): a
        held cell stays exactly at rest through all the step's stages, every other cell is
        projected. Deciding per stage instead made the starts depend on the step length and
        on RKC's stage weights (signed: a cell that stage 1 started, stage 2 could stop)."""
        out = acc
        g = self.state.grav.cell(e, i)
        if ti.static(self.state.phys.law.hysteresis):
            flag = ti.cast(self.state.rest[i, j, e], ti.i32)
            if ti.static(first):
                # nested, not `and`: Taichi's `and` evaluates both sides, and holds() (the start
                # coefficient mu_S) on every moving cell cost ~5 % of a fingers step
                if (flag & REST) != 0:
                    if self.state.phys.holds(e, acc, tau, g) == 1:
                        flag |= HELD
                        self.state.rest[i, j, e] = ti.cast(flag, ti.i8)
            if (flag & HELD) != 0:
                out[1] = 0.0
                if ti.static(not self.state.is_1d):
                    out[self.state.HV] = 0.0
            else:
                out = self.state.phys.project_friction(e, acc, tau, spd0, hb, g)
        else:
            out = self.state.phys.project_friction(e, acc, tau, spd0, hb, g)
        return out

    @staticmethod
    def _first_state(n: int, rate: int, rmask: int) -> int:
        return next(k for k in range(n) if k != rate and not (rmask >> k) & 1)

    @ti.func
    def keep_rest(
        self, e, acc, r, i, j, n: ti.template(), rate: ti.template(), rmask: ti.template(), ss
    ):
        """A cell at rest after the projection whose state terms all hold the same h and h phi
        and whose rates of h and h phi are all zero (no mass crossed its faces: _x_face) keeps
        that h and h phi bitwise: the stage weights of the states sum to 1, but their rounded
        sum need not give the same bits, and a deposit must not creep by round-off."""
        f = ti.static(self._first_state(n, rate, rmask))
        out = acc
        moving = acc[1] != 0.0
        if ti.static(not self.state.is_1d):
            moving = moving or acc[self.state.HV] != 0.0
        # a moving cell (most of a flow) reads no term again: the test costs one branch there
        if not moving:
            ref = self.state.q[ss[f], i, j, e]
            keep = 1
            for k in ti.static(range(n)):
                if ti.static(k == rate):
                    if r[0] != 0.0:
                        keep = 0
                    if ti.static(self.state.seg):
                        if r[self.state.HPHI] != 0.0:
                            keep = 0
                elif ti.static((rmask >> k) & 1):
                    v = self.state.q[ss[k], i, j, e]
                    if v[0] != 0.0:
                        keep = 0
                    if ti.static(self.state.seg):
                        if v[self.state.HPHI] != 0.0:
                            keep = 0
                elif ti.static(k != f):
                    v = self.state.q[ss[k], i, j, e]
                    if v[0] != ref[0]:
                        keep = 0
                    if ti.static(self.state.seg):
                        if v[self.state.HPHI] != ref[self.state.HPHI]:
                            keep = 0
            if keep == 1:
                out[0] = ref[0]
                if ti.static(self.state.seg):
                    out[self.state.HPHI] = ref[self.state.HPHI]
        return out

    def wet_extent(self, slot: int, t) -> tuple[int, int, int, int]:
        """(first, last) x index with a cell h >= h_min after filling ghosts, (NX, -1) if
        none; then (first, last) x index of a live cell, one that may change in the next step
        (_quiescent), found only where resting regions are skipped (else (NX, -1)). Member
        0's; every member's then by `member_extents` (t: one per member in a batch)."""
        self.state.set_time(t)
        if self.state.skip_rest and self.state.mask_inflow != self.state.inflow_on(t):
            # the inflow stopped since the last step began: the inlet is a wall now, and the
            # rest mask, taken with the inflow's ghost cells, says nothing of it
            self.state.forget_rest()
        w = self._wet_extent(slot, self.state.serial_loops())
        return int(w[0]), int(w[1]), int(w[2]), int(w[3])

    def member_extents(self) -> list[tuple[int, int, int, int]]:
        """Each member's extents of the last wet scan (`wet_extent`)."""
        return [tuple(int(v) for v in row) for row in self.state.wet.to_numpy()]

    @ti.kernel
    def _wet_extent(self, s: ti.i32, serial: ti.template()) -> ti.types.vector(4, ti.i32):
        """Ghost cells of slot s, then the smallest and largest x index (ghosts included) of a
        cell with h >= h_min or a moving film (`_live`), and of a live cell (see _quiescent),
        returned (one launch, no field read-back).

        Only the x range [wa - 3, wb + 3) around the wet range is scanned for wet cells: every
        cell outside it is a dry film (the wet range is the wet extent plus a margin, and a
        step writes nothing further out), and whatever could put wet cells there (set,
        set_params) makes the ranges whole again. A fingers run's early steps then scan the
        front, not the empty chute. Live cells are looked for on the range the last step
        wrote, [a - 3, b + 3) around the active range: every cell beyond it was quiescent when
        it was left out, and nothing has touched it since."""
        self.ghosts.fill(s)
        ti.loop_config(serialize=True)  # (a handful of numbers)
        for e in range(self.state.M):
            self.state.wet[e, 0] = self.state.NX
            self.state.wet[e, 1] = -1
            self.state.wet[e, 2] = self.state.NX
            self.state.wet[e, 3] = -1
        lo = ti.max(self.state.wrng[0] - 3, 0)
        hi = ti.min(self.state.wrng[1] + 3, self.state.NX)
        # the live scan: interior cells only (their neighbours, ghosts included, are read)
        llo = ti.max(self.state.act[0] - 3, self.state.gx)
        lhi = ti.min(self.state.act[1] + 3, self.state.gx + self.state.nx)
        B = ti.static(self.state.rows_per_block)
        P = ti.static(self.state.row_pieces)  # pieces of a row, as in _stability
        ti.loop_config(serialize=serial)
        for it, e in ti.ndrange(piece_count(lo, hi, B, P), self.state.M):
            hmin = self.state.par[e, Params.H_MIN]
            i0, j0, j1 = piece_at(it, lo, B, P, self.state.gy, self.state.ny)
            first = self.state.NX
            last = -1
            lfirst = self.state.NX
            llast = -1
            for r in range(B):
                i = i0 + r
                if i < hi:
                    scan_live = llo <= i < lhi
                    for j in range(j0, j1):
                        if self._live(self.state.q[s, i, j, e], hmin):
                            first = ti.min(first, i)
                            last = ti.max(last, i)
                        if ti.static(self.state.skip_rest):
                            if scan_live:
                                if self._quiescent(e, s, i, j) == 0:
                                    lfirst = ti.min(lfirst, i)
                                    llast = ti.max(llast, i)
            # an atomic per piece only where it moves a bound (see _stability)
            if last >= 0:
                if first < self.state.wet[e, 0]:
                    ti.atomic_min(self.state.wet[e, 0], first)
                if last > self.state.wet[e, 1]:
                    ti.atomic_max(self.state.wet[e, 1], last)
            if llast >= 0:
                if lfirst < self.state.wet[e, 2]:
                    ti.atomic_min(self.state.wet[e, 2], lfirst)
                if llast > self.state.wet[e, 3]:
                    ti.atomic_max(self.state.wet[e, 3], llast)
        return ti.Vector(
            [self.state.wet[0, 0], self.state.wet[0, 1], self.state.wet[0, 2], self.state.wet[0, 3]]
        )

    @ti.func
    def _quiescent(self, e, s, i, j):
        """1 where cell (i, j) sat out the last step exactly unchanged, and would sit out the
        next one as well if nothing within the step's reach has changed: it was at rest at
        the step's start, the static friction held it (HELD) or it is dry (_dry_film), and its four
        neighbours were at rest too. No mass then crossed its faces (rest_face), so
        keep_rest kept its h and h phi bitwise and its momentum stayed 0. Whether the static
        friction holds a cell does not depend on the step length (Physics.holds), so the same
        data around the cell give the same answer in the next step: a cell further than the
        next step's reach from every live cell keeps its bits without being computed. (Rest
        mask of the last step: REST from its start, HELD from its first stage.)"""
        r = ti.cast(self.state.rest[i, j, e], ti.i32)
        q = 0
        if (r & REST) != 0:
            if (r & HELD) != 0 or self._dry_film(e, self.state.q[s, i, j, e][0]):
                nb = ti.cast(self.state.rest[i - 1, j, e], ti.i32) & ti.cast(
                    self.state.rest[i + 1, j, e], ti.i32
                )
                if ti.static(not self.state.is_1d):
                    nb &= ti.cast(self.state.rest[i, j - 1, e], ti.i32)
                    nb &= ti.cast(self.state.rest[i, j + 1, e], ti.i32)
                if (nb & REST) != 0:
                    q = 1
        return q

    @ti.func
    def _dry_film(self, e, h):
        """A cell that no source acts on (Physics.acts): h = 0 where films flow (the split
        sweeps), thinner than h_min in the unsplit scheme."""
        return not self.state.phys.acts(e, h)

    @ti.func
    def _live(self, q, hmin):
        """Whether a cell of conserved state q is wet (h >= h_min) or a moving film (its
        momentum, which is zero exactly where its velocity is: RestRules.moving)."""
        out = q[0] >= hmin
        if not out:
            out = self.moving(q)
        return out

    @ti.func
    def moving(self, w):
        """Whether primitives w have a velocity."""
        out = w[1] != 0.0
        if ti.static(not self.state.is_1d):
            out = out or w[self.state.HV] != 0.0
        return out

    def rest_state(self, member: int = 0) -> dict[str, np.ndarray] | None:
        """What the skipping of resting regions needs besides slot 0, for a checkpoint of
        member ``member``: its rest mask of the last step and the active and wet ranges (None
        without skipping)."""
        if not self.state.skip_rest:
            return None
        on = -1 if self.state.mask_inflow is None else int(self.state.mask_inflow)
        return {
            "rest_mask": self.state.rest.to_numpy()[..., self.state._member(member)],
            "ranges": np.array([*self.state.active, *self.state.wet_range, on], dtype=np.int64),
        }

    def restore_rest_state(
        self, rest_mask: np.ndarray, ranges: np.ndarray, member: int = 0
    ) -> None:
        """Inverse of `rest_state` (after slot 0 was set): the next step then skips
        what the run it continues would have skipped, so a resumed run keeps its bits."""
        if not self.state.skip_rest:
            return
        full = self.state.rest.to_numpy()
        full[..., self.state._member(member)] = np.asarray(rest_mask).astype(np.int8)
        self.state.rest.from_numpy(full)
        a, b, wa, wb, on = (int(v) for v in ranges)
        self.state.set_active(a, b, (wa, wb))
        self.state.mask_inflow = None if on < 0 else bool(on)

    @ti.func
    def both_at_rest(self, e, i, j, i1, j1):
        """Whether cells (i, j) and (i1, j1) were both at rest at the step's start."""
        r = ti.cast(self.state.rest[i, j, e], ti.i32) & ti.cast(self.state.rest[i1, j1, e], ti.i32)
        return (r & REST) != 0
