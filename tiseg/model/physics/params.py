"""Indices of the run-time numbers in the operator's parameter field.

The slots below are those every scene has. A component with numbers of its own (a transport
function of `tiseg.model.physics.segregation`, the viscosity of `tiseg.model.physics.viscosity`, a
friction law of `tiseg.model.physics.friction`)
stores them after `Params.COUNT`, at indices it is given when the operator is built
(`tiseg.model.physics.param_layout.ParamLayout`), so a switched-off component has no slots at all.
"""


class Params:
    """Indices of run-time numbers in the parameter field."""

    G_COS, G_SIN, H_MIN, H_EPS4, U_EPS, THETA, WENO_EPS = range(7)
    PHI_REF, DX, DY = range(7, 10)
    IN_H, IN_U, IN_ON = range(10, 13)
    # reciprocals, so that the kernels multiply instead of divide (a division costs several
    # multiplications on a CPU, and the inner loops are bound by arithmetic, not memory); the
    # WENO smoothness indicators are scaled by 1/h_ref and 1/u_ref
    INV_DX, INV_DY, INV_H_REF, INV_U_REF = range(13, 17)
    COUNT = 17  # the first slot of the components' numbers
