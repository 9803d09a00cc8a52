"""The compile step's memos (tiseg.backend._memoise_source_positions) change nothing Taichi
builds or says: a kernel's error still names its own line, however often it is compiled."""

import pytest


def _broken_kernel(ti):
    @ti.kernel
    def broken(x: ti.f64) -> ti.f64:
        y = x * 2.0
        return y + not_defined_anywhere  # noqa: F821

    return broken


def test_a_kernel_error_names_its_line_every_time(ti_cpu):
    import taichi as ti

    from taichi.lang.ast.ast_transformer_utils import ASTTransformerContext

    assert getattr(ASTTransformerContext.get_pos_info, "tiseg_memo", False)
    messages = []
    for _ in range(3):  # a fresh kernel object each time, as a new simulation makes
        with pytest.raises(ti.TaichiCompilationError) as err:
            _broken_kernel(ti)(1.0)
        messages.append(str(err.value))
    assert "not_defined_anywhere" in messages[0]
    assert "return y + not_defined_anywhere" in messages[0]  # the source line, from the memo
    assert messages[0] == messages[1] == messages[2]


def test_two_kernels_on_the_same_lines_of_different_functions_keep_their_texts(ti_cpu):
    import taichi as ti

    @ti.kernel
    def first(x: ti.f64) -> ti.f64:
        return x + missing_one  # noqa: F821

    @ti.kernel
    def second(x: ti.f64) -> ti.f64:
        return x + missing_two  # noqa: F821

    texts = []
    for k in (first, second, first):
        with pytest.raises(ti.TaichiCompilationError) as err:
            k(1.0)
        texts.append(str(err.value))
    assert "missing_one" in texts[0] and "missing_two" in texts[1] and texts[2] == texts[0]
