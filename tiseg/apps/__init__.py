"""What users run: the command line and its commands, the live viewer, parameter sweeps on Dask,
benchmarks, run-time estimates, the paper's figures and the documentation generators."""
