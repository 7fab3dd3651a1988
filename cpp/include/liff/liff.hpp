// liff: Light Field Features in scale and depth (Dansereau, Girod, Wetzstein).
//
// Public C++ API. A light field arrives as one stacked cv::Mat:
//   * 4-D, sizes {T, S, V, U}: view row, view column, pixel row, pixel column;
//     1 channel (grey), 2 (grey + alpha), 3 (BGR, converted to grey by luminance)
//     or 4 (BGRA); alpha is a per-sample validity weight a >= 0 and the focal
//     stack becomes sum(a L) / sum(a);
//     depth CV_8U (/255), CV_16U (/65535), CV_32F or CV_64F (taken as given);
//   * 2-D (V x U, 1 to 4 channels): a single view, i.e. a 1x1 light field, for
//     which LiFF behaves as SIFT.
//
// Slope convention: a scene point at (x, y) in the centre view appears at
//   (x - slope * (s - s_c), y - slope * (t - t_c))   in view (t, s),
// with s_c = (S - 1) / 2 and t_c = (T - 1) / 2. This equals the disparity of the
// HCI 4D light field benchmark (pixels per view step).
//
// Keypoints are cv::SIFT-compatible: pt in centre-view pixels (integer
// coordinates at pixel centres), size a diameter, angle in degrees, response the
// absolute DoG contrast, octave packed as cv::SIFT packs it. The slope travels in
// class_id = round(slope * kSlopeScale); read it back with keypointSlope().
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>  // OpenCV 5 keeps this as a compatibility header

namespace liff {

/// Fixed-point scale of the slope stored in cv::KeyPoint::class_id.
constexpr double kSlopeScale = 65536.0;

/// The slope (pixels per view step) stored in a keypoint's class_id.
double keypointSlope(const cv::KeyPoint& keypoint);

/// class_id that encodes a slope: round(slope * kSlopeScale).
int slopeToClassId(double slope);

/// LiFF detector and descriptor: SIFT extended to the 4-D light field.
class CV_EXPORTS_W LiFF : public cv::Feature2D {
 public:
  /// @param nfeatures          keep the best n features by response (0 = all)
  /// @param nOctaveLayers      DoG layers per octave (as cv::SIFT)
  /// @param contrastThreshold  as cv::SIFT: DoG contrast >= contrastThreshold / nOctaveLayers
  /// @param edgeThreshold      principal-curvature ratio limit (as cv::SIFT)
  /// @param sigma              Gaussian sigma of the base octave (as cv::SIFT)
  /// @param firstSlope         first slope of the focal stack (pixels per view step)
  /// @param lastSlope          last slope of the focal stack
  /// @param numSlopes          slopes in linspace(firstSlope, lastSlope, numSlopes);
  ///                           0 = automatic: the smallest odd number >= max(T, S)
  /// @param descriptorType     CV_32F or CV_8U (as cv::SIFT)
  /// @param rootSift           L1-normalise then square-root the descriptor (RootSIFT)
  static cv::Ptr<LiFF> create(int nfeatures = 0, int nOctaveLayers = 3,
                              double contrastThreshold = 0.04, double edgeThreshold = 10,
                              double sigma = 1.6, double firstSlope = -1, double lastSlope = 1,
                              int numSlopes = 0, int descriptorType = CV_32F,
                              bool rootSift = false);

  virtual void setNFeatures(int nfeatures) = 0;
  virtual int getNFeatures() const = 0;
  virtual void setNOctaveLayers(int nOctaveLayers) = 0;
  virtual int getNOctaveLayers() const = 0;
  virtual void setContrastThreshold(double contrastThreshold) = 0;
  virtual double getContrastThreshold() const = 0;
  virtual void setEdgeThreshold(double edgeThreshold) = 0;
  virtual double getEdgeThreshold() const = 0;
  virtual void setSigma(double sigma) = 0;
  virtual double getSigma() const = 0;
  virtual void setFirstSlope(double firstSlope) = 0;
  virtual double getFirstSlope() const = 0;
  virtual void setLastSlope(double lastSlope) = 0;
  virtual double getLastSlope() const = 0;
  virtual void setNumSlopes(int numSlopes) = 0;
  virtual int getNumSlopes() const = 0;
  virtual void setDescriptorType(int descriptorType) = 0;
  virtual int getDescriptorType() const = 0;
  virtual void setRootSift(bool rootSift) = 0;
  virtual bool getRootSift() const = 0;

  /// Memory detectAndCompute may use beyond its input, in megabytes (2^20 bytes).
  /// 0 (default) = automatic: the memory available when a call starts (Linux:
  /// MemAvailable, capped by the cgroup limit; no limit where unknown); +infinity =
  /// no limit. When the estimated need exceeds it, fewer slices are built at once;
  /// if even one at a time does not fit, the call throws cv::Error::StsNoMem naming
  /// the estimate and the limit, before allocating anything large. Not saved by write().
  virtual void setMemoryLimitMB(double megabytes) = 0;
  virtual double getMemoryLimitMB() const = 0;

  /// The slopes the focal stack is built at for a light field of T x S views
  /// (resolves numSlopes = 0; a 1x1 light field has the single slope
  /// (firstSlope + lastSlope) / 2).
  virtual std::vector<double> slopesFor(int T, int S) const = 0;

  cv::String getDefaultName() const override;
};

}  // namespace liff
