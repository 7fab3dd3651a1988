"""Structure from motion with COLMAP (through pycolmap) on features computed elsewhere.

The pipeline: :func:`write_database` stores images with their keypoints and SIFT-like
descriptors in a fresh COLMAP database, :func:`match` matches every pair exhaustively
and verifies each pair geometrically (or, for light fields of a calibrated camera,
:func:`match_by_pose` matches each pair by its metric relative pose),
:func:`reconstruct` runs COLMAP's incremental mapper, :func:`metric_scale` scales a
model to metres by the slopes, and :func:`table_metrics` computes the columns of the
paper's SfM table
(Dansereau et al., CVPR 2019, Table 1, after Schoenberger et al., CVPR 2017). Needs
``pip install liff[sfm]`` (pycolmap >= 4).

Its modules, one step of the pipeline each (every name here is one of theirs):

- :mod:`~liff.colmap.conversions`: keypoints, descriptors and images as COLMAP takes
  them (the conventions below), and the paper's greyscale for SfM;
- :mod:`~liff.colmap.database`: writing a fresh database (:class:`FeatureImage`);
- :mod:`~liff.colmap.matching`: exhaustive matching, or matching by metric pose
  (:class:`PairPose`);
- :mod:`~liff.colmap.mapping`: COLMAP's incremental mapper, or a metric model from the
  pair poses (:class:`SfmResult`);
- :mod:`~liff.colmap.metrics`: the paper's table, and why images were left out;
- :mod:`~liff.colmap.scale`: a model in metres (:class:`MetricScale`).

Conventions crossed here:

- Pixel coordinates: OpenCV puts integer coordinates at pixel centres, COLMAP at pixel
  corners, so a keypoint at OpenCV (x, y) is COLMAP (x + 0.5, y + 0.5); likewise the
  principal point.
- Scale: ``cv2.KeyPoint.size`` is a diameter, 2 sigma; COLMAP's keypoint scale is sigma.
- Orientation: ``cv2.KeyPoint.angle`` is in degrees in image coordinates (x right, y
  down), from +x towards +y, i.e. clockwise as seen on screen (turning an image's content
  counter-clockwise by 30 degrees lowers cv2.SIFT's angles by 30). COLMAP's orientation
  is the same angle in radians, so ``orientation = radians(angle)``, reduced to
  [-pi, pi) as COLMAP's own extractor reports it (checked against COLMAP's SIFT on the
  same images: median difference 2-3 degrees). Keypoints without one (angle -1) get 0.
- Descriptors: cv2.SIFT and liff store ``round(512 * d)`` of a unit-norm d, saturated
  to [0, 255] (in float32 or uint8), which is COLMAP's own uint8 format already, so they
  are only cast. :func:`root_sift` turns them into RootSIFT on the same scale.
"""

try:
    import pycolmap  # noqa: F401  (first, so that without it the message says how to install it)
except ImportError as error:  # pragma: no cover - exercised only without the extra
    raise ImportError("liff.colmap needs pycolmap: pip install 'liff[sfm]'") from error

from .conversions import descriptors_to_colmap, grey_uint8_image, keypoints_to_colmap, prepare_light_field, root_sift
from .database import FeatureImage, PathLike, colmap_log, describe_sizes, write_database
from .mapping import SfmResult, mapper_options, reconstruct, reconstruct_from_poses
from .matching import PANORAMIC_BASELINE, PairPose, match, match_by_pose, matching_options
from .metrics import left_out_images, table_metrics
from .scale import MAX_BASELINE_RELATIVE_SIGMA, MetricScale, metric_scale, scale_reconstruction

__all__ = [
    "FeatureImage", "MAX_BASELINE_RELATIVE_SIGMA", "MetricScale", "PANORAMIC_BASELINE",
    "PairPose", "PathLike", "SfmResult", "colmap_log", "describe_sizes",
    "descriptors_to_colmap", "grey_uint8_image", "keypoints_to_colmap", "left_out_images",
    "mapper_options", "match", "match_by_pose", "matching_options", "metric_scale",
    "prepare_light_field", "reconstruct", "reconstruct_from_poses", "root_sift",
    "scale_reconstruction", "table_metrics", "write_database",
]
