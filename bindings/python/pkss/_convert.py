# SPDX-License-Identifier: MIT
"""Open3D inputs without importing Open3D: an object is converted only when
its type comes from the ``open3d`` package, so ``import pkss`` never loads
Open3D and plain arrays pay one attribute lookup."""
from __future__ import annotations

from typing import Any, Callable


def open3d_points(obj: Any, what: str, invalid: Callable[[str], Exception]) -> Any:
    """``o3d.t.geometry.PointCloud`` -> its positions; ``o3d.core.Tensor`` ->
    a NumPy array (copied to the host first when it lives on a GPU). Any
    other object (the legacy ``o3d.geometry.PointCloud`` included, which has
    ``.points``) is returned as it is."""
    module = getattr(type(obj), "__module__", "") or ""
    if not module.startswith("open3d"):
        return obj
    if hasattr(obj, "point") and not hasattr(obj, "points"):  # tensor PointCloud
        try:
            obj = obj.point["positions"]
        except (KeyError, AttributeError, RuntimeError, TypeError):
            raise invalid("%s: the Open3D tensor PointCloud has no 'positions' attribute "
                          "(an empty cloud?)" % what) from None
    if hasattr(obj, "numpy") and callable(obj.numpy):  # o3d.core.Tensor
        if hasattr(obj, "cpu"):
            obj = obj.cpu()
        return obj.numpy()
    return obj
