from typing import Any

from lodkit.kernel import Kernel

class MaxEdgeKernel(Kernel):
    max_length: float
    weight: float
    def prepare(self, ctx: Any, options: dict) -> None: ...
