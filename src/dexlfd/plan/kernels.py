"""The planner's numba kernels compiled ahead of the first plan: :func:`warm_kernels`.

The kernels (``forcing``, ``dmp``, ``dmp_rollout``, ``quaternion_dmp``) are
``njit(cache=True)``: compiled once per machine, about 5 s of CPU, then loaded from
numba's on-disk cache. A process that calls :func:`warm_kernels` (``dexlfd demo``
does it in the background while it tracks the video and learns, ``dexlfd teach``
while it records) leaves them in that cache, so the plan stage loads instead of
compiling. It also makes the reach band every pick-and-place checks against
(:func:`dexlfd.plan.reach.top_down_radius`: the forward kinematics of a 241 x 241
joint grid, once a process, ~0.06 s of the first plan's CPU). The signatures are the ones the
planner calls with (C-contiguous float64 arrays, float64 scalars, an int64 count);
``tests/plan/test_kernels.py`` checks that a plan after the warm-up compiles nothing new.
"""

from __future__ import annotations

__all__ = ["kernel_signatures", "warm_kernels"]


def kernel_signatures() -> list[tuple[object, tuple[object, ...]]]:
    """Each kernel dispatcher with the argument types the planner calls it with."""
    from importlib import import_module

    from numba import float64, int64

    # the modules themselves (dexlfd.plan.forcing the attribute is the function)
    forcing, dmp, dmp_rollout, quaternion_dmp = (
        import_module(f"dexlfd.plan.{m}")
        for m in ("forcing", "dmp", "dmp_rollout", "quaternion_dmp")
    )

    a1, a2 = float64[::1], float64[:, ::1]  # C-contiguous 1-D and 2-D
    return [
        (forcing._lwr_kernel, (a1, a1, a2, a1, a1, float64, a2)),
        (forcing._forcing_kernel, (a1, a1, a1, float64, a2, a2)),
        (dmp._gradient, (a2, a1, a2)),
        (dmp_rollout._linear_rollout, (a2, a2, a2, float64, a1, a1, a2, a2, a2, a2)),
        (
            quaternion_dmp._quat_rollout,
            (a1, a1, a1, a1, a1, a2, float64, float64, float64, int64, a2, a2),
        ),
    ]


def warm_kernels() -> int:
    """Compile (or load from numba's cache) every planner kernel; returns how many.

    Each lands in numba's on-disk cache (next to the source, or numba's cache folder
    when that is read-only), where every later process finds it. The reach band is
    made too, in this process (module docstring).
    """
    from dexlfd.plan.reach import top_down_radius

    sigs = kernel_signatures()
    for kernel, args in sigs:
        kernel.compile(args)  # type: ignore[attr-defined]
    top_down_radius(0.0)
    return len(sigs)
