"""The version of tiseg, in one place (read by pyproject.toml, the command line and the files
tiseg writes). A module of its own so that reading it imports nothing else."""

__version__ = "0.1.0"
