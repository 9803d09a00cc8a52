"""A run: the simulation loop, callbacks on schedules, guards, checkpoints, the run folder and
the checks made before work starts (memory, disk)."""
