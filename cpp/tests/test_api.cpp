// The public C++ API where the Python tests cannot reach it directly: cv::Exception
// on bad input, cv::Feature2D routing, detection of a known blob, FileStorage.
#include <liff/liff.hpp>

#include <gtest/gtest.h>

#ifdef __linux__
#include <sys/wait.h>
#include <unistd.h>
#endif

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <tuple>
#include <vector>

namespace {

// Passes if `fn` throws a cv::Exception whose message contains `word`.
::testing::AssertionResult throwsWith(const std::function<void()>& fn, const std::string& word) {
  try {
    fn();
  } catch (const cv::Exception& e) {
    if (e.err.find(word) != std::string::npos) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "message without '" << word << "': " << e.err;
  }
  return ::testing::AssertionFailure() << "no cv::Exception (expected one naming '" << word
                                       << "')";
}

// A T x S x V x U light field of one Gaussian blob (sigma 3 px, on 0.3 grey) whose
// centre-view position is (x, y) at the given slope (CONVENTIONS.md: view (t, s) sees
// it at (x - slope (s - s_c), y - slope (t - t_c))).
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

// The blob every detection test looks for.
constexpr double kBlobX = 30.4, kBlobY = 33.6, kBlobSlope = -0.35;

cv::Mat blobScene() { return blobLightField(5, 5, 64, 64, kBlobX, kBlobY, kBlobSlope); }

bool sameKeypoints(const std::vector<cv::KeyPoint>& a, const std::vector<cv::KeyPoint>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!(a[i].pt == b[i].pt && a[i].size == b[i].size && a[i].angle == b[i].angle &&
          a[i].response == b[i].response && a[i].octave == b[i].octave &&
          a[i].class_id == b[i].class_id))
      return false;
  return true;
}

// --- Identity and cv::Feature2D routing -----------------------------------------------

TEST(Feature2DInterface, NameDescriptorAndNormAreSiftLike) {
  const cv::Ptr<liff::LiFF> d = liff::LiFF::create();
  EXPECT_EQ(d->getDefaultName(), "Feature2D.LiFF");
  EXPECT_EQ(d->descriptorSize(), 128);
  EXPECT_EQ(d->descriptorType(), CV_32F);
  EXPECT_EQ(d->defaultNorm(), cv::NORM_L2);
  EXPECT_FALSE(d->empty());
}

TEST(Feature2DInterface, SlopeRoundTripsThroughClassId) {
  // 0.375 = 24576 / 65536 is exact in the fixed-point class_id.
  const cv::KeyPoint k(0, 0, 1, -1, 0, 0, liff::slopeToClassId(0.375));
  EXPECT_EQ(liff::keypointSlope(k), 0.375);
}

TEST(Feature2DInterface, DetectThroughTheBaseClassValidatesLikeDetectAndCompute) {
  // cv::Feature2D::detect returns nothing for an empty image; LiFF's override routes
  // to detectAndCompute, which says the input is empty.
  const cv::Ptr<cv::Feature2D> base = liff::LiFF::create();
  std::vector<cv::KeyPoint> kps;
  EXPECT_TRUE(throwsWith([&] { base->detect(cv::Mat(), kps); }, "empty"));
}

// The table's parameters, in its order, as create()'s positional arguments: a
// positional overload that lacks one does not compile here, and a value that lands in
// another parameter's place shows in the getters (every value differs from its default).
TEST(Parameters, PositionalCreateTakesTheTablesParametersInTheirOrder) {
  liff::Parameters custom;
  custom.nfeatures = 17;
  custom.nOctaveLayers = 4;
  custom.contrastThreshold = 0.031;
  custom.edgeThreshold = 7.5;
  custom.sigma = 1.3;
  custom.firstSlope = -0.75;
  custom.lastSlope = 1.25;
  custom.numSlopes = 9;
  custom.descriptorType = CV_8U;
  custom.rootSift = true;
  custom.firstOctave = 0;
  const liff::Parameters defaults;
#define LIFF_EXPECT_NOT_DEFAULT(Type, name, Name, value, help) \
  EXPECT_NE(custom.name, defaults.name) << #name " needs a value of its own in this test";
  LIFF_PARAMETERS(LIFF_EXPECT_NOT_DEFAULT)
#undef LIFF_EXPECT_NOT_DEFAULT
#define LIFF_ARGUMENT(Type, name, Name, value, help) std::make_tuple(custom.name),
  const auto arguments = std::tuple_cat(LIFF_PARAMETERS(LIFF_ARGUMENT) std::tuple<>());
#undef LIFF_ARGUMENT
  const cv::Ptr<liff::LiFF> d =
      std::apply([](auto... values) { return liff::LiFF::create(values...); }, arguments);
#define LIFF_EXPECT_SET(Type, name, Name, value, help) EXPECT_EQ(d->get##Name(), custom.name) << #name;
  LIFF_PARAMETERS(LIFF_EXPECT_SET)
#undef LIFF_EXPECT_SET
}

TEST(Feature2DInterface, DetectAndComputeCalledApartThroughTheBaseClassEqualDetectAndCompute) {
  const cv::Mat lf = blobScene();
  const cv::Ptr<liff::LiFF> d = liff::LiFF::create();
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  d->detectAndCompute(lf, cv::noArray(), kps, desc);
  ASSERT_FALSE(kps.empty());

  const cv::Ptr<cv::Feature2D> base = d;
  std::vector<cv::KeyPoint> detected;
  base->detect(lf, detected);
  EXPECT_TRUE(sameKeypoints(detected, kps));
  std::vector<cv::KeyPoint> given = kps;
  cv::Mat computed;
  base->compute(lf, given, computed);
  EXPECT_TRUE(sameKeypoints(given, kps));
  ASSERT_EQ(computed.size(), desc.size());
  EXPECT_EQ(cv::norm(desc, computed, cv::NORM_INF), 0);
}

// --- Bad input: a cv::Exception naming what was expected, never a crash ---------------

TEST(BadInput, EmptyLightFieldIsRefused) {
  std::vector<cv::KeyPoint> kps;
  EXPECT_TRUE(throwsWith([&] { liff::LiFF::create()->detect(cv::Mat(), kps); }, "empty"));
}

TEST(BadInput, ThreeDimensionalMatIsRefused) {
  const int sizes[3] = {4, 8, 8};
  const cv::Mat cube(3, sizes, CV_32F, cv::Scalar(0));
  std::vector<cv::KeyPoint> kps;
  EXPECT_TRUE(throwsWith([&] { liff::LiFF::create()->detect(cube, kps); }, "dimensions"));
}

TEST(BadInput, Int32ElementsAreRefused) {
  std::vector<cv::KeyPoint> kps;
  EXPECT_TRUE(throwsWith(
      [&] { liff::LiFF::create()->detect(cv::Mat(32, 32, CV_32S, cv::Scalar(0)), kps); },
      "uint8"));
}

TEST(BadInput, FiveChannelsAreRefused) {
  std::vector<cv::KeyPoint> kps;
  EXPECT_TRUE(throwsWith(
      [&] { liff::LiFF::create()->detect(cv::Mat(32, 32, CV_8UC(5), cv::Scalar(0)), kps); },
      "channels"));
}

TEST(BadInput, NegativeAlphaIsRefused) {
  std::vector<cv::KeyPoint> kps;
  EXPECT_TRUE(throwsWith(
      [&] { liff::LiFF::create()->detect(cv::Mat(32, 32, CV_32FC2, cv::Scalar(0.5, -1)), kps); },
      "negative weight"));
}

TEST(BadInput, NaNValueIsRefused) {
  cv::Mat withNaN(32, 32, CV_32F, cv::Scalar(0.5));
  withNaN.at<float>(3, 4) = NAN;
  std::vector<cv::KeyPoint> kps;
  EXPECT_TRUE(throwsWith([&] { liff::LiFF::create()->detect(withNaN, kps); }, "NaN"));
}

TEST(BadInput, MaskOfTheWrongSizeIsRefused) {
  const cv::Mat image(32, 32, CV_32F, cv::Scalar(0.5)), mask(16, 16, CV_8U, cv::Scalar(1));
  std::vector<cv::KeyPoint> kps;
  EXPECT_TRUE(throwsWith([&] { liff::LiFF::create()->detect(image, kps, mask); }, "mask"));
}

TEST(BadInput, ZeroOctaveLayersIsRefused) {
  EXPECT_TRUE(throwsWith([] { liff::LiFF::create()->setNOctaveLayers(0); }, "nOctaveLayers"));
}

TEST(BadInput, NegativeSigmaIsRefused) {
  EXPECT_TRUE(throwsWith([] { liff::LiFF::create()->setSigma(-1); }, "sigma"));
}

TEST(BadInput, DescriptorTypeOtherThanFloatOrByteIsRefused) {
  EXPECT_TRUE(
      throwsWith([] { liff::LiFF::create()->setDescriptorType(CV_16U); }, "descriptorType"));
}

TEST(BadInput, FirstSlopeAboveLastSlopeIsRefusedByCreateAndAtDetectTime) {
  // create() takes the whole set and checks the order; setters take one slope at a
  // time, so detect() checks it again.
  EXPECT_TRUE(throwsWith([] { liff::LiFF::create(0, 3, 0.04, 10, 1.6, 1, -1); }, "firstSlope"));
  const cv::Ptr<liff::LiFF> d = liff::LiFF::create();
  d->setFirstSlope(1);
  d->setLastSlope(-1);
  const cv::Mat lf = blobLightField(3, 3, 32, 32, 16, 16, 0);
  std::vector<cv::KeyPoint> kps;
  EXPECT_TRUE(throwsWith([&] { d->detect(lf, kps); }, "firstSlope"));
}

TEST(BadInput, MemoryLimitTooSmallThrowsStsNoMemBeforeDetecting) {
  const cv::Ptr<liff::LiFF> d = liff::LiFF::create();
  d->setMemoryLimitMB(0.01);
  std::vector<cv::KeyPoint> kps;
  try {
    d->detect(blobScene(), kps);
    FAIL() << "no cv::Exception for a 0.01 MB memory limit";
  } catch (const cv::Exception& e) {
    EXPECT_EQ(e.code, cv::Error::StsNoMem);
    EXPECT_NE(e.err.find("memory limit"), std::string::npos) << e.err;
  }
}

// --- Detection of a known blob ----------------------------------------------------------

TEST(Detection, BlobIsFoundAtItsPositionAndSlope) {
  std::vector<cv::KeyPoint> kps;
  liff::LiFF::create()->detect(blobScene(), kps);
  bool found = false;
  for (const cv::KeyPoint& k : kps)
    found |= std::hypot(k.pt.x - kBlobX, k.pt.y - kBlobY) < 0.3 &&
             std::abs(liff::keypointSlope(k) - kBlobSlope) < 0.05;
  EXPECT_TRUE(found) << kps.size() << " keypoints, none within 0.3 px and 0.05 slope";
}

TEST(Detection, OpaqueAlphaChannelChangesNothing) {
  const cv::Mat lf = blobScene();
  const cv::Ptr<liff::LiFF> d = liff::LiFF::create();
  std::vector<cv::KeyPoint> grey, withAlpha;
  d->detect(lf, grey);
  ASSERT_FALSE(grey.empty());
  cv::Mat greyAlpha;
  cv::merge(std::vector<cv::Mat>{lf, cv::Mat(4, lf.size.p, CV_32F, cv::Scalar(1))}, greyAlpha);
  d->detect(greyAlpha, withAlpha);
  EXPECT_TRUE(sameKeypoints(withAlpha, grey));
}

// A sub-array of a larger 4-D Mat is read where it is (views with continuous rows, as
// when only views are cropped) or converted view by view (rows cropped too, or 8-bit):
// either way the same keypoints as its continuous copy.
TEST(Detection, SubArrayOfALargerLightFieldIsTheSameAsItsCopy) {
  const cv::Mat lf = blobScene();  // 5 x 5 x 64 x 64
  const int sizes[4] = {7, 6, 70, 64}, wider[4] = {7, 6, 70, 75};
  const cv::Ptr<liff::LiFF> d = liff::LiFF::create();
  for (const int* outer : {sizes, wider})
    for (int depth : {CV_32F, CV_8U}) {
      cv::Mat big(4, outer, depth, cv::Scalar(0)), scene;
      lf.convertTo(scene, depth, depth == CV_8U ? 255.0 : 1.0);
      const cv::Range inside[4] = {cv::Range(1, 6), cv::Range(0, 5), cv::Range(3, 67),
                                   cv::Range(outer[3] - 64, outer[3])};
      cv::Mat sub = big(inside);
      scene.copyTo(sub);
      ASSERT_FALSE(sub.isContinuous());
      std::vector<cv::KeyPoint> fromSub, fromCopy;
      d->detect(sub, fromSub);
      d->detect(sub.clone(), fromCopy);
      EXPECT_FALSE(fromCopy.empty());
      EXPECT_TRUE(sameKeypoints(fromSub, fromCopy)) << "U = " << outer[3] << ", depth " << depth;
    }
}

// --- FileStorage --------------------------------------------------------------------------

TEST(Persistence, FileStorageRoundTripKeepsEveryParameter) {
  const cv::Ptr<liff::LiFF> a = liff::LiFF::create(7, 4, 0.02, 12, 1.8, -1.5, 0.5, 9, CV_8U, true);
  cv::FileStorage out(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  a->write(out);
  const std::string text = out.releaseAndGetString();
  const cv::Ptr<liff::LiFF> b = liff::LiFF::create();
  b->read(cv::FileStorage(text, cv::FileStorage::READ | cv::FileStorage::MEMORY).root());
  EXPECT_EQ(b->getNFeatures(), 7);
  EXPECT_EQ(b->getNOctaveLayers(), 4);
  EXPECT_EQ(b->getContrastThreshold(), 0.02);
  EXPECT_EQ(b->getEdgeThreshold(), 12);
  EXPECT_EQ(b->getSigma(), 1.8);
  EXPECT_EQ(b->getFirstSlope(), -1.5);
  EXPECT_EQ(b->getLastSlope(), 0.5);
  EXPECT_EQ(b->getNumSlopes(), 9);
  EXPECT_EQ(b->getDescriptorType(), CV_8U);
  EXPECT_TRUE(b->getRootSift());
}

TEST(Persistence, ReadOfABadValueThrowsAndChangesNothing) {
  const cv::Ptr<liff::LiFF> d = liff::LiFF::create(7);
  const std::string bad = "%YAML:1.0\n---\nnfeatures: 3\nsigma: -2\n";
  EXPECT_TRUE(throwsWith(
      [&] {
        d->read(cv::FileStorage(bad, cv::FileStorage::READ | cv::FileStorage::MEMORY).root());
      },
      "sigma"));
  EXPECT_EQ(d->getNFeatures(), 7);  // nfeatures: 3 came first but was not applied
  EXPECT_EQ(d->getSigma(), 1.6);
}

}  // namespace

// --- hostile parameter files (liff/parameter_file.hpp) -------------------------------------

namespace {

std::string repeat(const std::string& s, int n) {
  std::string out;
  for (int i = 0; i < n; ++i) out += s;
  return out;
}

std::string deepYaml(int n) {
  return "%YAML:1.0\n---\na: " + std::string(n, '[') + std::string(n, ']') + "\n";
}

}  // namespace

TEST(ParameterFile, NestingBeyondTheLimitIsRefusedBeforeOpenCVParsesIt) {
  // 100,000 levels overflow the stack of OpenCV's recursive parser (SIGSEGV)
  for (const std::string& text :
       {deepYaml(100000), "%YAML:1.0\n---\na: " + std::string(200000, '-') + "\n",
        "{\"a\": " + std::string(100000, '[') + "}",
        "<?xml version=\"1.0\"?>\n<opencv_storage>" + repeat("<a>", 100000),
        // found by fuzzing the check against OpenCV: type tags before block sequences
        "%YAML:1.0\n---\na: " + repeat("!}  -", 100000),
        "%YAML:1.0\n---\na: " + repeat("    -!- ", 60000),
        "%YAML:1.0\n---\na: " + repeat("!x: ", 100000),
        "%YAML:1.0\n---\na: " + repeat("/:- !/>", 60000)})
    EXPECT_TRUE(throwsWith([&] { liff::openParameterText(text, "deep"); }, "nests more than 64"));
  EXPECT_NO_THROW(liff::openParameterText(deepYaml(30), "shallow"));
}

TEST(ParameterFile, ReadOfAPathChecksTheFileAndHidesFeature2DRead) {
  const std::string path = ::testing::TempDir() + "liff_deep.yml";
  {
    std::ofstream out(path);
    out << deepYaml(100000);
  }
  const cv::Ptr<liff::LiFF> d = liff::LiFF::create(7);
  EXPECT_TRUE(throwsWith([&] { d->read(path); }, "nests more than 64"));
  EXPECT_TRUE(throwsWith([&] { d->read(path + ".missing"); }, "no parameter file"));
  EXPECT_TRUE(throwsWith([&] { d->read(::testing::TempDir()); }, "not a regular file"));
  {
    std::ofstream out(path);
    out << "%YAML:1.0\n---\nnfeatures: 3\n";
  }
  d->read(path);
  EXPECT_EQ(d->getNFeatures(), 3);
  std::remove(path.c_str());
}

TEST(ParameterFile, ADocumentStartingWithSpacesIsScannedWithinItsBounds) {
  // (found by AddressSanitizer: the character before the first one was read)
  EXPECT_TRUE(throwsWith([] { liff::checkParameterText("  -a: 1\n", "spaces"); }, "column 0"));
  EXPECT_NO_THROW(liff::checkParameterText(" ", "spaces"));
}

TEST(ParameterFile, YamlLayoutsThatHangOpenCVAreRefused) {
  // OpenCV 4.6's YAML parser loops forever on each of these
  for (const char* text : {"%YAML:1.0\n---\nnfeatures: 3\n...\n-x\n", "%YAML:1.0\n -<\n]\n-",
                           "%YAML:1.0\n--- a: 1\n-x\n", "%YAML:1.0\n---\n!!map a:},-\n---\n\n- ["})
    EXPECT_TRUE(throwsWith([&] { liff::checkParameterText(text, "hang"); }, "expected a YAML map"));
  EXPECT_NO_THROW(liff::openParameterText("%YAML:1.0\n---\na: 1\n...\n---\nb: 2\n", "two"));
}

TEST(ParameterFile, SizeAndBinaryContentAreRefused) {
  EXPECT_TRUE(throwsWith(
      [&] {
        liff::checkParameterText("%YAML:1.0\n---\n" + std::string(2 << 20, ' ') + "\n", "big");
      },
      "larger than 1048576 bytes"));
  EXPECT_TRUE(throwsWith(
      [&] { liff::checkParameterText(std::string("%YAML:1.0\na: 1\0", 15), "nul"); }, "NUL"));
  EXPECT_TRUE(throwsWith(
      [&] { liff::checkParameterText("%YAML:1.0\na: !!binary |\n  ]]]]\n", "b"); }, "base64"));
  EXPECT_TRUE(
      throwsWith([&] { liff::checkParameterText("%YAML:1.0\r---\n", "cr"); }, "carriage return"));
}

TEST(ParameterFile, IntegersBeyondAnIntAndNonBinaryBooleansAreRefusedAsWritten) {
  const cv::Ptr<liff::LiFF> d = liff::LiFF::create(7);
  const auto read = [&](const std::string& text) {
    d->read(liff::openParameterText(text, "parameters").root());
  };
  EXPECT_TRUE(throwsWith([&] { read("%YAML:1.0\n---\nnfeatures: 4294967297\n"); },
                         "nfeatures = 4294967297, which does not fit an int"));
  EXPECT_TRUE(throwsWith([&] { read("{\n  \"nfeatures\": 99999999999999999999999\n}\n"); },
                         "nfeatures = 99999999999999999999999"));
  EXPECT_TRUE(throwsWith([&] { read("%YAML:1.0\n---\nrootSift: .nan\n"); },
                         "rootSift = nan; expected 0 or 1"));
  EXPECT_TRUE(throwsWith([&] { read("%YAML:1.0\n---\nnOctaveLayers: 1e10\n"); },
                         "nOctaveLayers = 10000000000; expected an integer"));
  EXPECT_EQ(d->getNFeatures(), 7);
  read("%YAML:1.0\n---\nnfeatures: 2147483647\nrootSift: 1\n");
  EXPECT_EQ(d->getNFeatures(), 2147483647);
  EXPECT_TRUE(d->getRootSift());
}

#ifdef __linux__
// The check's bound against OpenCV's parser itself: documents of a random short
// pattern repeated to 400 KB (deep enough to overflow its stack if the pattern nests),
// and every one the check passes parsed in a child process, which must not crash.
TEST(ParameterFile, NoDocumentTheCheckPassesCrashesOpenCVsParser) {
  const std::vector<std::string> tokens = {
      "[", "]", "{", "}", ":", "-", " ", "\n", "'", "\"", "#", "!", "\\", "/", "*", ",", "a",
      "<a>", "</a>", "<!--", "-->", "/>", "x: ", "- ", "  ", "1", "!!str ", "\"k\": ", "/*"};
  const std::vector<std::string> heads = {"%YAML:1.0\n---\n", "{", "%YAML:1.0\n---\na: ",
                                          "<?xml version=\"1.0\"?>\n<opencv_storage>",
                                          "{\"a\": "};
  std::mt19937 random(1);
  int parsed = 0;
  for (int trial = 0; trial < 400; ++trial) {
    std::string pattern;
    for (int k = 1 + int(random() % 5); k > 0; --k) pattern += tokens[random() % tokens.size()];
    std::string text = heads[random() % heads.size()];
    while (text.size() < 400000) text += pattern;
    try {
      liff::checkParameterText(text, "fuzz");
    } catch (const cv::Exception&) {
      continue;  // refused: never reaches OpenCV
    }
    ++parsed;
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      try {
        cv::FileStorage fs(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
      } catch (...) {
      }
      _exit(0);
    }
    int status = 0;
    waitpid(child, &status, 0);
    EXPECT_TRUE(WIFEXITED(status)) << "OpenCV's parser crashed on a document the check passed, "
                                      "pattern ["
                                   << pattern << "]";
  }
  EXPECT_GT(parsed, 100);
}
#endif

// --- The report of a call's slope range ----------------------------------------------------

// A hand-set range that ends before the blob's slope pins its features at the end: the
// report counts them and carries the survey's slopes beyond; with the automatic range it
// carries the reach and no end survey.
TEST(SlopeRangeReport, CountsFeaturesAtHandSetEndsAndSurveysBeyondThem) {
  const double slope = 1.2;
  const cv::Mat lf = blobLightField(5, 5, 96, 96, 47.3, 45.6, slope);
  const cv::Ptr<liff::LiFF> d = liff::LiFF::create();
  d->setFirstSlope(-0.5);
  d->setLastSlope(0.5);
  std::vector<cv::KeyPoint> kps;
  d->detect(lf, kps);
  ASSERT_FALSE(kps.empty());
  liff::SlopeRangeReport report = d->getSlopeRangeReport();
  EXPECT_FALSE(report.automaticRange);
  EXPECT_TRUE(std::isnan(report.automaticReach));
  EXPECT_EQ(report.T, 5);
  EXPECT_EQ(report.U, 96);
  EXPECT_EQ(report.slicesUsed, d->getSlicesUsed());
  EXPECT_EQ(report.searchedSlopes, d->getSearchedSlopes());
  EXPECT_EQ(report.featuresReturned, int(kps.size()));
  EXPECT_GE(report.featuresFound, report.featuresReturned);
  int atLast = 0;
  for (const cv::KeyPoint& k : kps) atLast += std::abs(liff::keypointSlope(k) - 0.5) < 1e-4;
  EXPECT_EQ(report.featuresAtLastSlope, atLast);
  EXPECT_GT(atLast, 0);
  EXPECT_EQ(report.featuresAtFirstSlope, 0);
  ASSERT_TRUE(report.endsSurveyed);
  ASSERT_FALSE(report.surveyedSlopes.empty());
  std::vector<double> surveyed = report.surveyedSlopes;
  std::nth_element(surveyed.begin(), surveyed.begin() + surveyed.size() / 2, surveyed.end());
  EXPECT_NEAR(surveyed[surveyed.size() / 2], slope, 0.3);

  d->setFirstSlope(-HUGE_VAL);
  d->setLastSlope(HUGE_VAL);
  d->detect(lf, kps);
  report = d->getSlopeRangeReport();
  EXPECT_TRUE(report.automaticRange);
  EXPECT_DOUBLE_EQ(report.automaticReach, 96 / (4.0 * 4));
  EXPECT_FALSE(report.endsSurveyed);
  EXPECT_EQ(report.featuresAtLastSlope, 0);
  EXPECT_TRUE(report.surveyedSlopes.empty());
}
