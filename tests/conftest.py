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
    field trees taken. Simulations free theirs when collected (tiseg.field_tree); renderers
    and viewer windows still hold plain fields until the runtime is reset."""
    import gc

    from tiseg import backend

    gc.collect()  # simulations of the last file free their field trees (tiseg.field_tree)
    if backend.is_initialised() and backend.field_trees() > backend.MAX_FIELD_TREES // 2:
        st = backend.state()
        backend.init(backend.requested_arch(st.arch), st.precision, st.threads, force=True)
    yield


_trees_at_reset = [0]  # field_tree.made() at the last reset
_held_by_fixtures: set = set()  # test files whose module-scoped fixtures hold fields


def _reset_if_nothing_holds_fields() -> bool:
    """Reset Taichi (same arch, precision, threads) when simulations were made since the last
    reset and none of them (nor a renderer or viewer) is alive any more; True if it did."""
    import gc

    from tiseg import backend, field_tree

    if not backend.is_initialised() or field_tree.made() == _trees_at_reset[0]:
        return False
    if field_tree.live():
        gc.collect()  # simulations that only reference cycles still hold
        if field_tree.live():
            return False
    st = backend.state()
    backend.init(backend.requested_arch(st.arch), st.precision, st.threads, force=True)
    _trees_at_reset[0] = field_tree.made()
    return True


@pytest.fixture(scope="session", autouse=True)
def _fresh_runtime_per_simulation():
    """A simulation made in a test after the test's earlier ones are gone starts in a fresh
    Taichi runtime, as the first one of a test does (see _fresh_runtime_per_test): its kernels
    then come from the offline cache (2-3 s for a small fingers scene) instead of being
    compiled again (6-9 s), since the cache keys hold SNode ids that only a reset starts from
    the same numbers again. Each simulation then runs in a runtime of its own, as it would in a
    new process. Only on the main thread: an in-process sweep's members run in worker threads,
    and never while anything holds Taichi fields (a twin kept alive keeps the runtime)."""
    import threading

    from tiseg.simulation import Simulation

    init = Simulation.__init__

    def __init__(self, *args, **kwargs):
        if threading.current_thread() is threading.main_thread():
            _reset_if_nothing_holds_fields()
        init(self, *args, **kwargs)

    Simulation.__init__ = __init__
    yield
    Simulation.__init__ = init


@pytest.fixture(autouse=True)
def _fresh_runtime_per_test(request):
    """Reset Taichi (0.1 s) before a test when the tests before it made simulations and
    nothing holds Taichi fields any more, so that its kernels come from Taichi's offline cache
    instead of being compiled again (3 s for a small fingers scene): the cache keys hold the
    fields' SNode ids, which only a reset starts again from the same numbers. A module-scoped
    fixture that keeps a simulation or a renderer alive keeps the runtime too."""
    module = request.module.__name__
    if module not in _held_by_fixtures and not _reset_if_nothing_holds_fields():
        from tiseg import field_tree

        if field_tree.live():  # a module-scoped fixture holds them: no reset before its file ends
            _held_by_fixtures.add(module)
    yield
