"""Plain NumPy version of the semi-discrete operator: the oracle of the Taichi kernels in tests
and the baseline of the benchmarks. Written for clarity, not speed."""

from .operator import ReferenceOperator

__all__ = ["ReferenceOperator"]
