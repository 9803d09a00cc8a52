"""Ensemble members as an axis of the operator's fields: one launch advances them all, and each
member's state is bitwise that of the same member in an operator of its own.

The members differ in their run-time numbers (inflow seed, friction, viscosity, slope) and so
in their states; the operator with two members and the two single operators take the same
steps (the same dt and stage counts), through the stepper of the scene and through RKC and
SSP-RK3, and must agree bit for bit in the states, the boundary budgets, the stability
numbers and the totals.
"""

import numpy as np
import pytest

from tiseg.errors import TisegError
from tiseg.run.simulation import Simulation
from tiseg.setup.initial import initial_state
from tiseg.setup.reading import load_scene
from tiseg.solver.numerics.config import config_from_scene
from tiseg.solver.numerics.operator import TaichiOperator
from tiseg.solver.timestepping import make_stepper, stepper_for

GRID = {"domain.resolution": 40, "output.times": [], "output.interval": 1.0}

# two members of each scene: different run-time numbers (no compiled option changes)
MEMBERS = {
    "fingers": ({"inflow.seed": 1}, {"inflow.seed": 7, "flow.nu": 1.0, "material.zeta_deg": 28}),
    "finite-release-deposit": ({}, {"material.zeta_deg": 31.5}),
    "channel": ({}, {"flow.nu": 0.2}),
}
RESOLUTION = {"channel": 250}  # (its chute is 8 cm wide)
# the scenes whose members take different stage counts (viscous; the other has no stiffness)
VARIED_STAGES = {"fingers", "channel"}


def _scenes(name):
    grid = {**GRID, "domain.resolution": RESOLUTION.get(name, GRID["domain.resolution"])}
    return [load_scene(name, {**grid, **m}) for m in MEMBERS[name]]


def _initial(scene, lay):
    """The scene's initial state; the fingers chute, empty at t = 0, as its steady layer
    h0, u0, phi0 instead (thick enough for the viscous stage counts to vary)."""
    q = initial_state(scene, lay)
    if scene.name == "fingers":
        f = scene.flow
        q[lay.H], q[lay.HU], q[lay.HV] = f.h0, f.h0 * f.u0, 0.0
        q[lay.HPHI] = f.h0 * f.phi0
    return q


def _steppers(scene):
    cfg = config_from_scene(scene)
    own = stepper_for(scene.numerics, is_1d=scene.is_1d, viscous=cfg.viscous)
    if own.split:
        return [own]
    return [own, make_stepper("ssprk3")]


@pytest.mark.parametrize("name", sorted(MEMBERS))
def test_members_step_as_each_member_alone(ti_cpu, name):
    scenes = _scenes(name)
    for k, stepper in enumerate(_steppers(scenes[0])):
        singles = [Simulation(s) for s in scenes]
        cfgs = [config_from_scene(s) for s in scenes]
        nslots = singles[0].op.nslots
        batch = TaichiOperator(cfgs[0], nslots=nslots, members=2)
        batch.set_params(cfgs[1], member=1)
        for e, s in enumerate(scenes):
            batch.set(0, initial_state(s, cfgs[e].layout), member=e)
        batch.reset_budget()
        for sim in singles:
            sim.op.reset_budget()
        t = 0.0
        # every operator takes one stability pass a step, then the step; dt and the stage
        # count are the first member's (choosing them per member is the driver's business)
        for n in range(6):
            nums = [sim.op.stability(0, t) for sim in singles]
            batch.stability(0, t)
            assert batch.member_stability() == nums, (name, k, n)
            rho = nums[0].rho_visc if stepper.split else nums[0].rho_stiff
            dt_cfl = 0.4 * cfgs[0].dx / max(nums[0].ax, 1.0)
            dt, stages = stepper.plan(dt_cfl, rho, 1.0)
            for op in (batch, *(s.op for s in singles)):
                stepper.index = n
                stepper.step(op, t, dt, stages)
            t += dt
        for e, sim in enumerate(singles):
            assert np.array_equal(batch.get(0, member=e), sim.op.get(0)), (name, k, e)
            assert np.array_equal(batch.budget(0, member=e), sim.op.budget(0)), (name, k, e)
            assert batch.sums(0, member=e) == sim.op.sums(0), (name, k, e)
        # the members really differ (else the test shows nothing)
        assert not np.array_equal(batch.get(0, member=0), batch.get(0, member=1))


def test_a_member_out_of_range_is_refused(ti_cpu):
    scene = _scenes("channel")[0]
    op = TaichiOperator(config_from_scene(scene), nslots=4, members=2)
    with pytest.raises(TisegError, match="members 0 to 1"):
        op.get(0, member=2)
    with pytest.raises(TisegError, match="whole number"):
        TaichiOperator(config_from_scene(scene), nslots=4, members=0)


@pytest.mark.parametrize("name", sorted(MEMBERS))
def test_members_take_their_own_steps(ti_cpu, name):
    """Each member plans its own step (dt and stage count from its own stability numbers)
    and a batch takes them all at once (Stepper.step_members): members with fewer RKC stages
    sit out the later ones, a member that stops early keeps its state while the other goes on,
    and every member stays bitwise the member alone."""
    scenes = _scenes(name)
    stepper = _steppers(scenes[0])[0]
    singles = [Simulation(s) for s in scenes]
    cfgs = [config_from_scene(s) for s in scenes]
    batch = TaichiOperator(cfgs[0], nslots=singles[0].op.nslots, members=2)
    batch.set_params(cfgs[1], member=1)
    for e, s in enumerate(scenes):
        batch.set(0, _initial(s, cfgs[e].layout), member=e)
        singles[e].op.set(0, _initial(s, cfgs[e].layout))
    batch.reset_budget()
    for sim in singles:
        sim.op.reset_budget()
    t = np.zeros(2)
    stages_seen = set()
    for n in range(8):
        running = np.array([True, n < 5])  # the second member stops after 5 steps
        nums = [sim.op.stability(0, t[e]) for e, sim in enumerate(singles) if running[e]]
        batch.set_running(running)
        batch.stability(0, t)
        assert batch.member_stability()[: len(nums)] == nums, (name, n)
        plans = []
        for e, num in enumerate(nums):
            rho = num.rho_visc if stepper.split else num.rho_stiff
            # the members' own (different) steps: the second at 0.7 of its limit
            cfl = 0.4 if e == 0 else 0.28
            plans.append(stepper.plan(cfl * cfgs[e].dx / max(num.ax, 1.0), rho, 1.0))
        plans += [(0.0, plans[0][1])] * (2 - len(plans))  # (a stopped member's numbers)
        dt = np.array([p[0] for p in plans])
        stages = [p[1] for p in plans]
        stages_seen.add(tuple(stages))
        stepper.index = n
        stepper.step_members(batch, t, dt, stages)
        for e, sim in enumerate(singles):
            if running[e]:
                stepper.step(sim.op, float(t[e]), float(dt[e]), stages[e])
        t = t + np.where(running, dt, 0.0)
    for e, sim in enumerate(singles):
        assert np.array_equal(batch.get(0, member=e), sim.op.get(0)), (name, e)
        assert np.array_equal(batch.budget(0, member=e), sim.op.budget(0)), (name, e)
    assert not np.array_equal(batch.get(0, member=0), batch.get(0, member=1))
    if name in VARIED_STAGES:
        # the members' stage counts differed in some step (else the idling went untested)
        assert any(a != b for a, b in stages_seen), stages_seen
