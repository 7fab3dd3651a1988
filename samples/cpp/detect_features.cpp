// LiFF from C++: build a small synthetic light field (a bright Gaussian blob at a
// known position and slope), detect and describe features, and check the answer.
// Exits non-zero if the blob is not found where it is, at the slope it has.
#include <liff/liff.hpp>

#include <cmath>
#include <cstdio>

int main() {
  const int T = 7, S = 7, V = 96, U = 96;
  const double blobX = 40.3, blobY = 51.7, radius = 3.0, slope = 0.45;

  // Stacked light field: a 4-D Mat {T, S, V, U}, float in [0, 1].
  const int sizes[4] = {T, S, V, U};
  cv::Mat lf(4, sizes, CV_32F);
  for (int t = 0; t < T; ++t)
    for (int s = 0; s < S; ++s)
      for (int v = 0; v < V; ++v)
        for (int u = 0; u < U; ++u) {
          // The blob appears at (x - slope (s - s_c), y - slope (t - t_c)) in view (t, s).
          const double cx = blobX - slope * (s - (S - 1) / 2.0);
          const double cy = blobY - slope * (t - (T - 1) / 2.0);
          const double r2 = (u - cx) * (u - cx) + (v - cy) * (v - cy);
          const int index[4] = {t, s, v, u};
          lf.at<float>(index) = float(0.3 + 0.5 * std::exp(-r2 / (2 * radius * radius)));
        }

  cv::Ptr<liff::LiFF> detector = liff::LiFF::create();
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  detector->detectAndCompute(lf, cv::noArray(), keypoints, descriptors);
  std::printf("%s: %zu keypoints, descriptors %d x %d\n", detector->getDefaultName().c_str(),
              keypoints.size(), descriptors.rows, descriptors.cols);

  bool found = false;
  for (const cv::KeyPoint& kp : keypoints) {
    const double distance = std::hypot(kp.pt.x - blobX, kp.pt.y - blobY);
    const double estimated = liff::keypointSlope(kp);
    std::printf("  (%.2f, %.2f) size %.2f angle %.1f slope %+.3f\n", kp.pt.x, kp.pt.y, kp.size,
                kp.angle, estimated);
    if (distance < 0.5 && std::abs(estimated - slope) < 0.05) found = true;
  }
  std::printf(found ? "blob found at its slope\n" : "blob NOT found\n");
  return found ? 0 : 1;
}
