"""The active x range of the operator and the choice of serial or parallel loops.

A collaborator of `tiseg.solver.numerics.operator.TaichiOperator`. The active range [a, b) holds
the x indices whose cells may change: cells outside are dry films (h < h_min) far from any wet
cell, whose rate is exactly zero, so skipping them is exact. The wet range [wa, wb), which
contains it, is what the next wet scan covers (wider where resting regions are left out). The
ranges live in small integer fields that the kernels read (``act``, ``wrng``; ``wet`` receives
the scan's result), and on the host as tuples (``active``, ``wet_range``), so a range that does
not change costs no field write (each is a kernel launch).

Serial loops: below `SERIAL_CELLS` cells a CPU launch runs its loops on the calling thread.
Each parallel loop costs a fixed ~80 us on the 2-core machines here (the thread pool's hand-off,
measured with a one-line kernel; a serialised loop costs ~1 us), and an evaluation has about ten
of them: on small grids that, not arithmetic, set the pace. Each kernel is compiled for both
modes (a template argument) and the choice is made per launch from the cells it covers (the
active x range), so a fingers run goes serial while its front is short and parallel once it is
long. The crossover measured on 2 threads (benchmarks/README.md section 7): 50-75k cells.
"""

import taichi as ti

SERIAL_CELLS = 60_000


class ActiveRange:
    def __init__(self, ft, lay, serial: bool | None, threads: int, on_cpu: bool, members: int = 1):
        """Fields in the field tree ``ft`` (before it is finalised); ``serial``: run every loop
        on the calling thread (True), never (False), or decide per launch (None); ``members``:
        the ensemble members, each with its own wet scan (one range for all)."""
        self.gx, self.nx, self.NX, self.NY = lay.gx, lay.nx, lay.NX, lay.NY
        self.force_serial = None if serial is None else bool(serial)
        self._threads = threads
        self._on_cpu = on_cpu
        self._serial_whole = self.serial_for(lay.NX * lay.NY)
        self.act = ft.field(ti.i32, 2)
        # first and last x index of a wet cell, then of a live one (the operator's wet scan)
        self.wet = ft.field(ti.i32, (members, 4))
        # the x range the wet scan covers (besides the halo): the wet cells and their margin,
        # which contains the active range act and, with resting regions skipped, more
        self.wrng = ft.field(ti.i32, 2)
        self.active = None
        self.wet_range = None
        self._serial_active = self._serial_whole

    def set(self, a: int, b: int, wet: tuple[int, int] | None = None) -> bool:
        """Set the active range to the interior x indices [a, b) (clamped to the interior) and
        the wet range to ``wet`` (by default [a, b), widened to hold it); True where the
        active range changed."""
        (a, b), (wa, wb) = clamp_range(self, a, b, wet)
        if self.wet_range != (wa, wb):
            self.wrng[0] = wa
            self.wrng[1] = wb
            self.wet_range = (wa, wb)
        if self.active == (a, b):
            return False
        self.act[0] = a
        self.act[1] = b
        self.active = (a, b)
        # the cells a launch on this range covers: the range and the 3-cell halo of the stencil
        self._serial_active = self.serial_for(min(b - a + 6, self.NX) * self.NY)
        return True

    def serial_for(self, cells: int) -> bool:
        """Loops over ``cells`` cells on one thread? On a CPU with one thread, or at most
        SERIAL_CELLS cells; never on a GPU; ``force_serial`` overrides."""
        if self.force_serial is not None:
            return self.force_serial
        if not self._on_cpu:
            return False
        return self._threads == 1 or cells <= SERIAL_CELLS

    def serial_loops(self, whole: bool = False) -> bool:
        """Whether the next launch runs its loops on one thread: a launch on the active range,
        or on the whole grid (``whole``). Both modes give the same bits
        (tests/test_determinism.py)."""
        return self._serial_whole if whole else self._serial_active


def clamp_range(lay, a: int, b: int, wet=None) -> tuple[tuple[int, int], tuple[int, int]]:
    """The active range [a, b) clamped to the interior x indices of ``lay`` (which has gx,
    nx), and the wet range (by default [a, b)) widened to hold it."""
    a = max(lay.gx, int(a))
    b = max(a, min(lay.gx + lay.nx, int(b)))
    wa, wb = (a, b) if wet is None else wet
    wa = min(max(lay.gx, int(wa)), a)
    wb = max(min(lay.gx + lay.nx, int(wb)), b)
    return (a, b), (wa, wb)


def row_pieces(lay, threads: int, on_cpu: bool) -> int:
    """How many pieces along y a reduction over rows cuts each row into (2D; 1 in 1D, whose
    blocks of rows are already short): enough that the smallest range whose loops run in
    parallel, SERIAL_CELLS cells, gives each of ``threads`` CPU threads 512 iterations
    (Taichi's least chunk of a parallel loop on the CPU), or 8 cells a piece on a GPU; at
    least 4 cells a piece."""
    if lay.is_1d or lay.ny < 8:
        return 1
    if not on_cpu:
        return max(1, lay.ny // 8)
    rows = max(1, SERIAL_CELLS // lay.NY)  # of the smallest range with parallel loops
    want = -(-512 * max(1, threads) // rows)
    return max(1, min(want, lay.ny // 4))


@ti.func
def piece_count(lo, hi, rows_per_block: ti.template(), pieces: ti.template()):
    """Iterations of a loop over the rows [lo, hi) in blocks of ``rows_per_block`` rows, each
    row cut into ``pieces`` pieces along y (row_pieces)."""
    return (hi - lo + rows_per_block - 1) // rows_per_block * pieces


@ti.func
def piece_at(
    it,
    lo,
    rows_per_block: ti.template(),
    pieces: ti.template(),
    gy: ti.template(),
    ny: ti.template(),
):
    """Iteration ``it`` of that loop: (the block's first row, the piece's cells [j0, j1) of
    the interior rows [gy, gy + ny)); rows of the last block past the range's end are the
    caller's to skip."""
    n = ti.static((ny + pieces - 1) // pieces)  # cells of a piece
    j0 = gy + (it % pieces) * n
    return lo + (it // pieces) * rows_per_block, j0, ti.min(j0 + n, gy + ny)
