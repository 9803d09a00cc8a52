"""Shared test set-up: Taichi on the CPU in f64, initialised once per test session."""

import os

import pytest

os.environ.setdefault("TI_SKIP_VERSION_CHECK", "ON")
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "0")
os.environ.setdefault("MPLBACKEND", "Agg")


# The backend of the in-process tests: the CPU, unless TISEG_TEST_ARCH names another (the
# Vulkan tests run some test files again on software Vulkan this way, in a child process).
TEST_ARCH = os.environ.get("TISEG_TEST_ARCH", "cpu")


@pytest.fixture(scope="session")
def ti_cpu():
    """Taichi on the CPU (or TISEG_TEST_ARCH), double precision (what the round-off-level
    tests need)."""
    import tiseg

    return tiseg.init(TEST_ARCH, "f64")


@pytest.fixture(scope="module", autouse=True)
def _room_for_fields():
    """Start a test file with a fresh Taichi runtime only if the last ones left most of its
    field trees taken. Simulations free theirs when collected (tiseg.solver.field_tree); renderers
    and viewer windows still hold plain fields until the runtime is reset."""
    import gc

    from tiseg import backend

    gc.collect()  # simulations of the last file free their field trees (tiseg.solver.field_tree)
    if backend.is_initialised() and backend.field_trees() > backend.MAX_FIELD_TREES // 2:
        st = backend.state()
        backend.init(backend.requested_arch(st.arch), st.precision, st.threads, force=True)
    yield


_trees_at_reset = [0]  # field_tree.made() at the last reset
_held_by_fixtures: set = set()  # test files whose module-scoped fixtures hold fields


@pytest.fixture(autouse=True)
def _tiseg_log_level():
    """Give the next test the ``tiseg`` logger's level as it was: a command run in-process
    (`tiseg.log.configure`) sets it for the process, and after a ``-q`` (errors only) a later
    test's ``caplog`` would miss the warnings it checks."""
    from tiseg.log import logger

    level = logger.level
    yield
    logger.setLevel(level)


@pytest.fixture(autouse=True)
def _fresh_runtime_per_test(request):
    """Reset Taichi (0.1 s) before a test when the tests before it made simulations and
    nothing holds Taichi fields any more, so that its kernels come from Taichi's offline cache
    instead of being compiled again (3 s for a small fingers scene): the cache keys hold the
    fields' SNode ids, which only a reset starts again from the same numbers. A module-scoped
    fixture that keeps a simulation or a renderer alive keeps the runtime too."""
    import gc

    from tiseg import backend
    from tiseg.solver import field_tree

    module = request.module.__name__
    if (
        backend.is_initialised()
        and field_tree.made() != _trees_at_reset[0]
        and module not in _held_by_fixtures
    ):
        if field_tree.live():
            gc.collect()  # the last test's simulations, if only reference cycles hold them
        if field_tree.live() == 0:
            st = backend.state()
            backend.init(backend.requested_arch(st.arch), st.precision, st.threads, force=True)
            _trees_at_reset[0] = field_tree.made()
        else:  # a module-scoped fixture holds them: no reset before its file ends
            _held_by_fixtures.add(module)
    yield
