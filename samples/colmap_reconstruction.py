"""A COLMAP reconstruction from a folder of light fields, one per camera pose.

    python samples/colmap_reconstruction.py [FOLDER] --workspace ws

Every file or sub-folder of FOLDER that liff.io reads is one pose (an .npy/.npz, an
HCI or view folder, an ESLF image, ...). Without FOLDER, a built-in capture is written
first: 5 poses of a textured box scene seen by a 7x7 camera array. Each light field is
preprocessed as in the paper (luminance, gamma 0.5, histogram stretch), LiFF finds
features on it, and the centre views with those features go into a COLMAP database;
pycolmap then matches every pair and runs incremental mapping. Needs pycolmap
(`pip install liff[sfm]`).
"""

import argparse
import os
import sys

import numpy as np

import liff
from liff import captures, colmap, io
from liff.feature_file import centre_view


def write_built_in_capture(folder: str) -> None:
    os.makedirs(folder, exist_ok=True)
    capture = captures.make_capture(seed=1, n_poses=5, views=(7, 7), size=(240, 320))
    for i, light_field in enumerate(capture.light_fields):
        np.save(os.path.join(folder, f"pose{i:02d}.npy"), light_field)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", nargs="?", help="light fields, one per pose (default: built-in)")
    parser.add_argument("--workspace", default="colmap-workspace")
    args = parser.parse_args()

    folder = args.folder or os.path.join(args.workspace, "light_fields")
    if not args.folder:
        write_built_in_capture(folder)
    database = os.path.join(args.workspace, "database.db")
    if os.path.exists(database):
        os.remove(database)  # COLMAP's matcher needs a fresh database

    detector = liff.LiFF.create(contrastThreshold=0.02)  # the paper's SfM peak threshold x 3
    images = []
    for name in sorted(os.listdir(folder)):
        path = os.path.join(folder, name)
        try:
            light_field = io.read_light_field(path).light_field
        except ValueError as error:
            print(f"skipped {path}: {error}", file=sys.stderr)
            continue
        grey = colmap.prepare_light_field(light_field)  # uint8 (T, S, V, U)
        keypoints, descriptors = detector.detectAndCompute(grey, None)
        images.append(colmap.FeatureImage(name.split(".")[0] + ".png", centre_view(grey),
                                          keypoints, descriptors))
        print(f"{path}: {len(keypoints)} features")

    image_dir = os.path.join(args.workspace, "images")
    colmap.write_database(database, image_dir, images)
    colmap.match(database)
    result = colmap.reconstruct(database, image_dir, os.path.join(args.workspace, "sparse"))
    metrics = colmap.table_metrics(database, result)
    print(f"registered {metrics['registered']:.0%} of {len(images)} images, "
          f"{metrics['points3D']} 3D points, mean track length {metrics['track_length']:.2f}")
    return 0 if result.success else 1


if __name__ == "__main__":
    raise SystemExit(main())
