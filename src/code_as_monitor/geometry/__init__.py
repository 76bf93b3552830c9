"""Layer 1: geometry. Back-projection, multi-view fusion, outlier removal, element fitting, transforms.

The monitor helpers live in :mod:`code_as_monitor.geometry.helpers`; the synthetic test scene in
:mod:`code_as_monitor.geometry.synthetic` (not imported here). SciPy and scikit-learn are imported
lazily, inside the functions that need them.
"""

from code_as_monitor.geometry.backproject import (
    DEFAULT_MAX_DEPTH,
    backproject_mask,
    backproject_pixels,
    lift_depth,
    sample_depth,
    valid_depth,
)
from code_as_monitor.geometry.elements import (
    VOXEL_DIVISIONS,
    build_element,
    build_element_from_clouds,
    cap_cloud,
    ee_element,
    element_voxel_size,
    fine_voxel_size,
    fit_element_points,
    mask_cloud,
    part_cloud,
)
from code_as_monitor.geometry.fusion import fuse_points, remove_outliers, voxel_downsample
from code_as_monitor.geometry.transforms import compose, invert, make_transform, rotation_about, transform_points

__all__ = [
    "DEFAULT_MAX_DEPTH",
    "VOXEL_DIVISIONS",
    "backproject_mask",
    "backproject_pixels",
    "build_element",
    "build_element_from_clouds",
    "cap_cloud",
    "compose",
    "ee_element",
    "element_voxel_size",
    "fine_voxel_size",
    "fit_element_points",
    "fuse_points",
    "invert",
    "lift_depth",
    "make_transform",
    "mask_cloud",
    "part_cloud",
    "remove_outliers",
    "rotation_about",
    "sample_depth",
    "transform_points",
    "valid_depth",
    "voxel_downsample",
]
