"""The scene's source terms beyond (6.4) and their auxiliary fields, composed for the kernels.

`SourceTerms` receives the operator's state (`state.OperatorState`) and builds each chosen
term's Taichi function (`tiseg.model.physics.sources.SourceTerm.taichi`) for it; the
evaluation of L (`finite_volume.FiniteVolume.cell_rate`), the split sweeps
(`split.SplitSweeps`) and the stability pass (`reductions.StepReductions`) call `rate` and
`stiffness`, each behind ``ti.static(terms.on)``: without terms no code is compiled and no
field is allocated (the state's ``aux`` and ``srate`` are None).
"""

import numpy as np
import taichi as ti

from ...taichi_classes import data_oriented

from ...model.physics.sources import SOURCES, TaichiContext, aux_arrays, chosen_aux


@data_oriented
class SourceTerms:
    def __init__(self, state):
        """``state``: the operator's fields (``par``, ``w``, ``aux``) and layout constants."""
        cfg = state.cfg
        self.state = state
        self.names = tuple(cfg.sources)
        self.on = bool(self.names)
        self.aux_names = chosen_aux(self.names)
        index = {name: k for k, name in enumerate(self.aux_names)}
        self._rates, self._stiff = [], []
        for name in self.names:
            ctx = TaichiContext(
                par=state.par,
                base=state.params.base(f"source:{name}"),
                w=state.w,
                aux=state.aux,
                aux_index=index,
                nc=state.nc,
                is_1d=state.is_1d,
                seg=state.seg,
                H=state.H,
                HU=state.HU,
                HV=state.HV,
                HPHI=state.HPHI,
                fp=state.fp,
            )
            self._rates.append(SOURCES[name].taichi(ti, ctx))
            stiff = SOURCES[name].stiffness_taichi(ti, ctx)
            if stiff is not None:
                self._stiff.append(stiff)
        self.stiff_on = bool(self._stiff)

    def fill_aux(self, cfgs) -> None:
        """The auxiliary fields' values on every cell of each member, from the constants of
        ``cfgs``, the members' configurations."""
        if self.state.aux is None:
            return
        rows = []
        for cfg in cfgs:
            arrays = aux_arrays(cfg)
            rows.append(np.stack([arrays[n] for n in self.aux_names], axis=-1))
        self.state.aux.from_numpy(np.stack(rows, axis=2).astype(self.state.np_fp))

    @ti.func
    def rate(self, e, i, j):
        """The sum of the terms' rates at cell (i, j) of member e (nc components)."""
        r = ti.Vector.zero(self.state.fp, self.state.nc)
        for k in ti.static(range(len(self._rates))):
            r += self._rates[k](e, i, j)
        return r

    @ti.func
    def stiffness(self, e, i, j):
        """The sum of the terms' stiffness bounds at cell (i, j) of member e [1/s]."""
        s = ti.cast(0.0, self.state.fp)
        for k in ti.static(range(len(self._stiff))):
            s += self._stiff[k](e, i, j)
        return s
