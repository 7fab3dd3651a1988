// C++ checks of the public API that the Python tests cannot reach directly:
// cv::Exception on bad input, FileStorage round trip, Feature2D routing.
// Built with -DLIFF_BUILD_TESTS=ON and run by ctest.
#include <liff/liff.hpp>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>

namespace {

int checks = 0, failures = 0;

void check(bool ok, const std::string& what) {
  std::printf("%s %s\n", ok ? "ok  " : "FAIL", what.c_str());
  ++checks;
  if (!ok) ++failures;
}

// True if `fn` throws a cv::Exception whose message contains `word`.
bool throwsWith(const std::function<void()>& fn, const std::string& word) {
  try {
    fn();
  } catch (const cv::Exception& e) {
    if (e.err.find(word) != std::string::npos) return true;
    std::printf("     message was: %s\n", e.err.c_str());
    return false;
  }
  return false;
}

cv::Mat blobLightField(int T, int S, int V, int U, double x, double y, double slope) {
  const int sizes[4] = {T, S, V, U};
  cv::Mat lf(4, sizes, CV_32F);
  for (int t = 0; t < T; ++t)
    for (int s = 0; s < S; ++s)
      for (int v = 0; v < V; ++v)
        for (int u = 0; u < U; ++u) {
          const double cx = x - slope * (s - (S - 1) / 2.0), cy = y - slope * (t - (T - 1) / 2.0);
          const int idx[4] = {t, s, v, u};
          lf.at<float>(idx) =
              float(0.3 + 0.5 * std::exp(-((u - cx) * (u - cx) + (v - cy) * (v - cy)) / 18.0));
        }
  return lf;
}

}  // namespace

int main() {
  cv::Ptr<liff::LiFF> d = liff::LiFF::create();
  check(d->getDefaultName() == "Feature2D.LiFF", "default name");
  check(d->descriptorSize() == 128 && d->descriptorType() == CV_32F &&
            d->defaultNorm() == cv::NORM_L2 && !d->empty(),
        "descriptor size, type, norm, empty");
  check(liff::keypointSlope(cv::KeyPoint(0, 0, 1, -1, 0, 0, liff::slopeToClassId(0.375))) == 0.375,
        "slope round trip through class_id");

  // Bad input: cv::Exception naming what was expected, never a crash.
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  check(throwsWith([&] { d->detect(cv::Mat(), kps); }, "empty"), "empty light field");
  const int sizes3[3] = {4, 8, 8};
  check(throwsWith([&] { d->detect(cv::Mat(3, sizes3, CV_32F, cv::Scalar(0)), kps); },
                   "dimensions"),
        "3-D Mat");
  check(throwsWith([&] { d->detect(cv::Mat(32, 32, CV_32S, cv::Scalar(0)), kps); }, "uint8"),
        "int32 element type");
  check(throwsWith([&] { d->detect(cv::Mat(32, 32, CV_8UC(5), cv::Scalar(0)), kps); }, "channels"),
        "5 channels");
  check(throwsWith([&] { d->detect(cv::Mat(32, 32, CV_32FC2, cv::Scalar(0.5, -1)), kps); },
                   "negative weight"),
        "negative alpha");
  cv::Mat withNaN(32, 32, CV_32F, cv::Scalar(0.5));
  withNaN.at<float>(3, 4) = NAN;
  check(throwsWith([&] { d->detect(withNaN, kps); }, "NaN"), "NaN value");
  check(throwsWith([&] { d->detect(cv::Mat(32, 32, CV_32F, cv::Scalar(0.5)), kps,
                                   cv::Mat(16, 16, CV_8U, cv::Scalar(1))); },
                   "mask"),
        "mask of the wrong size");
  check(throwsWith([&] { d->setNOctaveLayers(0); }, "nOctaveLayers"), "nOctaveLayers = 0");
  check(throwsWith([&] { d->setSigma(-1); }, "sigma"), "sigma < 0");
  check(throwsWith([&] { d->setDescriptorType(CV_16U); }, "descriptorType"), "descriptor type");
  check(throwsWith([&] { liff::LiFF::create(0, 3, 0.04, 10, 1.6, 1, -1)->detect(
                             blobLightField(3, 3, 32, 32, 16, 16, 0), kps); },
                   "firstSlope"),
        "firstSlope > lastSlope at detect time");

  // Detection on a blob at a known position and slope; compute() agrees.
  const cv::Mat lf = blobLightField(5, 5, 64, 64, 30.4, 33.6, -0.35);
  d->detectAndCompute(lf, cv::noArray(), kps, desc);
  bool found = false;
  for (const cv::KeyPoint& k : kps)
    found |= std::hypot(k.pt.x - 30.4, k.pt.y - 33.6) < 0.3 &&
             std::abs(liff::keypointSlope(k) + 0.35) < 0.05;
  check(found, "blob found at its position and slope");
  std::vector<cv::KeyPoint> again = kps;
  cv::Mat desc2;
  d->compute(lf, again, desc2);
  check(again.size() == kps.size() && cv::norm(desc, desc2, cv::NORM_INF) == 0,
        "compute() on detected keypoints equals detectAndCompute()");

  // Grey + opaque alpha equals grey; a memory limit too small fails with StsNoMem.
  {
    cv::Mat withAlpha;
    const cv::Mat opaque(4, lf.size.p, CV_32F, cv::Scalar(1));
    cv::merge(std::vector<cv::Mat>{lf, opaque}, withAlpha);
    std::vector<cv::KeyPoint> alphaKps;
    d->detect(withAlpha, alphaKps);
    bool same = alphaKps.size() == kps.size();
    for (size_t i = 0; same && i < kps.size(); ++i)
      same = alphaKps[i].pt == kps[i].pt && alphaKps[i].class_id == kps[i].class_id;
    check(same, "opaque alpha channel changes nothing");
    cv::Ptr<liff::LiFF> small = liff::LiFF::create();
    small->setMemoryLimitMB(0.01);
    bool noMem = false;
    try {
      small->detect(lf, alphaKps);
    } catch (const cv::Exception& e) {
      noMem = e.code == cv::Error::StsNoMem && e.err.find("memory limit") != std::string::npos;
    }
    check(noMem, "memory limit too small throws StsNoMem before detecting");
  }

  // FileStorage round trip of every parameter, and read() of a bad value keeps the old ones.
  cv::Ptr<liff::LiFF> a = liff::LiFF::create(7, 4, 0.02, 12, 1.8, -1.5, 0.5, 9, CV_8U, true);
  cv::FileStorage out(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  a->write(out);
  const std::string text = out.releaseAndGetString();
  cv::Ptr<liff::LiFF> b = liff::LiFF::create();
  b->read(cv::FileStorage(text, cv::FileStorage::READ | cv::FileStorage::MEMORY).root());
  check(b->getNFeatures() == 7 && b->getNOctaveLayers() == 4 && b->getContrastThreshold() == 0.02 &&
            b->getEdgeThreshold() == 12 && b->getSigma() == 1.8 && b->getFirstSlope() == -1.5 &&
            b->getLastSlope() == 0.5 && b->getNumSlopes() == 9 && b->getDescriptorType() == CV_8U &&
            b->getRootSift(),
        "FileStorage round trip");
  const std::string bad = "%YAML:1.0\n---\nnfeatures: 3\nsigma: -2\n";
  check(throwsWith([&] { b->read(cv::FileStorage(bad, cv::FileStorage::READ |
                                                          cv::FileStorage::MEMORY).root()); },
                   "sigma") &&
            b->getNFeatures() == 7,
        "read() of a bad value throws and changes nothing");

  std::printf("%d passed, %d failed\n", checks - failures, failures);
  return failures == 0 ? 0 : 1;
}
