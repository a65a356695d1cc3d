"""CasADi functions evaluated through numpy buffers bound once.

A plain call of a CasADi function converts every numpy argument and result to CasADi's
``DM`` (≈ 60 µs for the planner's 4-state RK4 step, ≈ 0.5 ms for the inner problem's
Hessian); the hot paths — the inner spline solve's value, gradient and Hessian, the
planner's KKT check after every compiled solve and its warm-start shift — call the same
virtual machine through ``Function.buffer`` on arrays bound once, which gives the same
result to the bit.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

__all__ = ["BufferedFunction"]


class BufferedFunction:
    """Zero-copy evaluation of a CasADi function with dense inputs and outputs.

    Attributes:
        inputs: the bound input arrays (flat, CasADi's column-major order).
        outputs: the bound output arrays, rewritten by every evaluation.
    """

    def __init__(self, fn: ca.Function) -> None:
        """Bind one numpy array per input and output of ``fn``."""
        self.fn = fn
        self.inputs = [np.zeros(fn.nnz_in(i)) for i in range(fn.n_in())]
        self.outputs = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]
        self.shapes = [fn.size_out(i) for i in range(fn.n_out())]
        self._buf, self._eval = fn.buffer()
        # a.data: the array's memoryview (numpy's stubs give ndarray no __buffer__ before
        # Python 3.12). casadi's stub also lists the byte size, which its SWIG wrapper reads
        # from the buffer itself and refuses as a third argument.
        for i, a in enumerate(self.inputs):
            self._buf.set_arg(i, a.data)  # type: ignore[call-arg]
        for i, a in enumerate(self.outputs):
            self._buf.set_res(i, a.data)  # type: ignore[call-arg]

    def evaluate(self, *args: np.ndarray) -> list[np.ndarray]:
        """Copy ``args`` into the inputs and evaluate.

        Returns:
            :attr:`outputs` themselves (flat, overwritten by the next evaluation).
        """
        for dst, src in zip(self.inputs, args, strict=True):
            dst[:] = src
        self._eval()
        return self.outputs

    def __call__(self, *args: np.ndarray) -> list[np.ndarray]:
        """Evaluate; returns copies of the outputs, matrices in their shape."""
        self.evaluate(*args)
        # CasADi stores column-major; outputs here are vectors or symmetric/Jacobians
        return [
            out.reshape(shape[::-1]).T.copy() if shape[1] > 1 else out.copy()
            for out, shape in zip(self.outputs, self.shapes, strict=True)
        ]
