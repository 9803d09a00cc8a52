"""Shared test set-up: Taichi on the CPU in f64, initialised once per test session."""
import os

import pytest

os.environ.setdefault("TI_SKIP_VERSION_CHECK", "ON")
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "0")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(scope="session")
def ti_cpu():
    """Taichi on the CPU, double precision (what the round-off-level tests need)."""
    import tiseg
    return tiseg.init("cpu", "f64")
