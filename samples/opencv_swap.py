"""An ordinary OpenCV matching script with cv2.SIFT swapped for liff.LiFF.

The only changes from the SIFT version are marked "LiFF:": the detector, and that it
takes the light field (T, S, V, U[, C]) rather than one image. Matching (BFMatcher +
Lowe's ratio test), findHomography with RANSAC and drawMatches are untouched.

    python samples/opencv_swap.py --out matches.png

Two captures of the built-in textured, occluded scene, the second moved by (12, 7)
pixels; prints the matches, inliers and the translation recovered.
"""

import argparse

import cv2
import numpy as np

import liff
from liff import synthetic


def match_and_draw(detector, first, second, first_image, second_image):
    keypoints1, descriptors1 = detector.detectAndCompute(first, None)
    keypoints2, descriptors2 = detector.detectAndCompute(second, None)
    matcher = cv2.BFMatcher(cv2.NORM_L2)
    good = [m for m, n in matcher.knnMatch(descriptors1, descriptors2, k=2)
            if m.distance < 0.75 * n.distance]
    source = np.float32([keypoints1[m.queryIdx].pt for m in good]).reshape(-1, 1, 2)
    target = np.float32([keypoints2[m.trainIdx].pt for m in good]).reshape(-1, 1, 2)
    homography, inliers = cv2.findHomography(source, target, cv2.RANSAC, 3.0)
    picture = cv2.drawMatches(first_image, keypoints1, second_image, keypoints2, good, None,
                              matchesMask=inliers.ravel().tolist(),
                              flags=cv2.DrawMatchesFlags_NOT_DRAW_SINGLE_POINTS)
    return homography, int(inliers.sum()), len(good), picture


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="matches.png")
    parser.add_argument("--noise", type=float, default=1e-3, help="noise variance")
    args = parser.parse_args()

    scene = synthetic.textured_layers((9, 9, 200, 260), noise_variance=args.noise, contrast=0.3)
    lf = scene.light_field
    first, second = lf[:, :, :180, :240], lf[:, :, 7:187, 12:252]  # moved by (12, 7) px

    def centre(light_field):
        return np.round(light_field[4, 4] * 255).astype(np.uint8)

    detector = liff.LiFF.create()  # LiFF: instead of cv2.SIFT.create()
    homography, inliers, good, picture = match_and_draw(
        detector, first, second, centre(first), centre(second))  # LiFF: light fields in
    cv2.imwrite(args.out, picture)
    print(f"LiFF (light field): {good} ratio-test matches, {inliers} inliers; "
          f"translation ({homography[0, 2]:.2f}, {homography[1, 2]:.2f}), expected (-12, -7)")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
