"""Sub-commands of the `tiseg` command line; each module has ``register(subparsers)``."""
