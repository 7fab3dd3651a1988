// The core's check of a caller's value: one definition for every file that checks.
#pragma once

#include <opencv2/core.hpp>

namespace liff {
namespace detail {

/// Throws cv::Exception (StsOutOfRange) with "LiFF: " + `message` unless `ok`;
/// `message` names the value and what was expected.
inline void require(bool ok, const cv::String& message) {
  if (!ok) CV_Error(cv::Error::StsOutOfRange, "LiFF: " + message);
}

}  // namespace detail
}  // namespace liff
