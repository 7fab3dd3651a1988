"""The package's structure (issue 27): public names kept when modules are split."""

import importlib

import pytest

# What ``liff.colmap`` offered as one module (main at 868753f, before the split into a
# package): every name it defined. The names it imported from elsewhere (os, numpy,
# pycolmap, typing, liff.pose_graph's PairMeasurement, ...) were never its API.
COLMAP_NAMES = [
    "FeatureImage", "MAX_BASELINE_RELATIVE_SIGMA", "MetricScale", "PANORAMIC_BASELINE",
    "PairPose", "PathLike", "SfmResult", "colmap_log", "describe_sizes",
    "descriptors_to_colmap", "grey_uint8_image", "keypoints_to_colmap", "left_out_images",
    "mapper_options", "match", "match_by_pose", "matching_options", "metric_scale",
    "prepare_light_field", "reconstruct", "reconstruct_from_poses", "root_sift",
    "scale_reconstruction", "table_metrics", "write_database",
]
# ... and ``liff.hloc``'s, with the names it imported from liff.colmap.
HLOC_NAMES = [
    "Added", "DESCRIPTOR_NORM", "DIGEST_ATTR", "PAIR_DIGEST_ATTRS", "PAIR_NAME_ATTRS",
    "add_feature_files", "check_export", "check_file_kind", "check_pair_names",
    "feature_datasets", "feature_file_group", "features_digest", "features_in", "image_name",
    "match_scores", "names_to_pair", "updated", "write_features", "write_matches",
    "grey_uint8_image", "keypoints_to_colmap",
]


@pytest.mark.parametrize("module, names", [("liff.colmap", COLMAP_NAMES), ("liff.hloc", HLOC_NAMES)])
def test_public_names_are_kept(module, names):
    """Every public name of the module as it was is still importable from it."""
    imported = importlib.import_module(module)
    missing = [name for name in names if not hasattr(imported, name)]
    assert not missing, f"{module} lost {missing}"
    for name in names:  # and ``from module import name`` works as ``module.name`` does
        assert getattr(importlib.import_module(module), name) is getattr(imported, name)


def test_colmap_all_is_its_public_names():
    """``from liff.colmap import *`` gives what the module gave (its own names only)."""
    import liff.colmap

    assert sorted(liff.colmap.__all__) == sorted(COLMAP_NAMES)
