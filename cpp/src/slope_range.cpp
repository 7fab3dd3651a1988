#include "slope_range.hpp"
#include "profile.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <liff/liff.hpp>
#include <map>
#include <set>
#include <tuple>

#include "extrema.hpp"
#include "focal_stack.hpp"
#include "pipeline.hpp"
#include "scale_space.hpp"
#include "slope_sweep.hpp"

namespace liff {
namespace detail {
namespace {

/// Coarsest decimation of the survey, and the one it ends at when views allow.
constexpr int kCoarsestDecimation = 16;
constexpr int kFinestDecimation = 4;
/// The coarsest level needs views of at least this many pixels on the smaller side
/// (smaller, fine textures vanish and SIFT's image border takes most of the view)...
constexpr int kCoarsestSurveyView = 40;
/// ...and the finest keeps this many where it can (at most kFinestDecimation times
/// smaller than the light field), so that small structure stays visible to it; views
/// under twice kSmallestSurveyView are not surveyed.
constexpr int kFinestSurveyView = 64;
constexpr int kSmallestSurveyView = 32;
/// A finer level searches within this many of the coarser level's spacings of its slopes.
constexpr double kCandidateReach = 1.0;
/// A slope searched over the whole range counts when it holds more than this many
/// times the median number of features per slope.
constexpr double kDensityFactor = 3.0;
/// A surveyed slope is within this share of its level's spacing of the feature's own
/// (the sub-slice fit's error; docs/SLOPES.md).
constexpr double kSurveyUncertainty = 0.25;
/// A survey that finds nothing looks again at this share of the contrast threshold.
constexpr double kRetryContrastShare = 0.5;
/// The paper's rule of thumb, the range used when the survey finds nothing.
constexpr double kPaperRange = 1.0;

// Intervals of slopes [a, b], merged where they touch.
SlopeIntervals merged(std::vector<std::pair<double, double>> spans) {
  std::sort(spans.begin(), spans.end());
  SlopeIntervals out;
  for (const auto& span : spans) {
    if (!out.empty() && span.first <= out.back().second)
      out.back().second = std::max(out.back().second, span.second);
    else
      out.push_back(span);
  }
  return out;
}

// Grid positions k (slope origin + k * step) with a slope in one of `intervals` and in
// [lo, hi].
std::set<long> positionsIn(const SlopeIntervals& intervals, double step, double lo, double hi,
                           double origin = 0) {
  std::set<long> positions;
  for (const auto& [a, b] : intervals) {
    const long first = long(std::ceil((std::max(a, lo) - origin) / step - 1e-9));
    const long last = long(std::floor((std::min(b, hi) - origin) / step + 1e-9));
    for (long k = first; k <= last; ++k) positions.insert(k);
  }
  return positions;
}

// The plan of grid positions `searched` (slopes origin + k * step), each with its grid
// neighbours as unsearched guards where they are not searched themselves, except beyond
// a finite bound [lo, hi]: a slice at the bound then skips that side, as the ends of a
// hand-set range do, so no slope is reported beyond it.
SlopePlan guardedPlan(std::set<long> searched, double step, int T, int S, double origin = 0,
                      double lo = -HUGE_VAL, double hi = HUGE_VAL) {
  // A one-position gap between two runs would be built as both runs' guard anyway:
  // search it too.
  for (auto it = searched.begin(); it != searched.end(); ++it) {
    const auto next = std::next(it);
    if (next != searched.end() && *next == *it + 2) searched.insert(*it + 1);
  }
  std::set<long> all(searched);
  for (long k : searched)
    for (long guard : {k - 1, k + 1})
      if (origin + double(guard) * step >= lo - 1e-9 && origin + double(guard) * step <= hi + 1e-9)
        all.insert(guard);
  SlopePlan plan;
  plan.origin = origin;
  plan.step = step;
  for (long k : all) {
    plan.grid.push_back(int(k));
    plan.slopes.push_back(origin + double(k) * step);
    plan.searched.push_back(searched.count(k) > 0);
  }
  setBlurTarget(plan, T, S, true);
  return plan;
}

// The coherent features of one survey level, as full-resolution slopes: LiFF's
// detection on `small` (the light field decimated `factor` times) over the grid
// positions `searched` of spacing `step` (full-resolution units).
std::vector<double> surveyLevel(const LightField& small, int factor, const std::set<long>& searched,
                                double step, const Parameters& p, int batch) {
  SlopePlan plan = guardedPlan(searched, step / factor, small.T, small.S);
  Parameters survey = p;
  survey.nfeatures = 0;
  // The survey's own detection keeps SIFT's first octave whatever the caller's: the
  // decimated views' small features are what it measures slopes on.
  survey.firstOctave = kDefaultFirstOctave;
  const int octaves = numOctaves(small.viewSize(), survey.firstOctave);
  const Call call{survey, small,
                  plan,   ScaleSpaceSettings{survey.nOctaveLayers, p.sigma, octaves,
                                             survey.firstOctave, true},
                  batch,  std::max(kSlicesPerPass, batch + 1)};
  const Detections found = detectInSlices(call, cv::Mat(), false);
  // One coherence test per extremum (its orientations share position, size and slope).
  std::vector<cv::KeyPoint> unique;
  for (const cv::KeyPoint& kp : found.keypoints)
    if (unique.empty() || unique.back().pt != kp.pt || unique.back().size != kp.size ||
        unique.back().class_id != kp.class_id)
      unique.push_back(kp);
  std::vector<double> coherence(unique.size());
  parallelFor("survey coherence", cv::Range(0, int(unique.size())), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i)
      coherence[i] =
          viewCoherence(small, unique[i], keypointSlope(unique[i]), survey.nOctaveLayers);
  });
  std::vector<double> slopes;
  for (size_t i = 0; i < unique.size(); ++i)
    if (coherence[i] >= minCoherence(small.T * small.S))
      slopes.push_back(keypointSlope(unique[i]) * factor);
  return slopes;
}

// The plane sweep's slope intervals (full-resolution slopes within [lo, hi]) on `small`,
// the light field decimated `factor` times; a pixel votes only where LiFF's pre-test
// could keep its DoG response. Swept up to beyondLow below lo and beyondHigh above hi
// too (full-resolution slopes), to say whether structure lies there.
SweptSlopes textureSlopes(const LightField& small, int factor, double lo, double hi,
                          const Parameters& p, double beyondLow, double beyondHigh) {
  const float featureResponse = float(p.contrastThreshold / p.nOctaveLayers);
  SweptSlopes found = sweepSlopes(small, lo / factor, hi / factor,
                                  float(kPreThresholdShare) * featureResponse, featureResponse,
                                  beyondLow / factor, beyondHigh / factor);
  for (auto& [a, b] : found.intervals) {
    a *= factor;
    b *= factor;
  }
  return found;
}

// A half-automatic range's slopes when nothing it would search lies within its finite
// bound: `width` from the bound inward, [lo, lo + width] or [hi - width, hi].
std::pair<double, double> fromBound(double lo, double hi, double width) {
  return std::isfinite(lo) ? std::make_pair(lo, lo + width) : std::make_pair(hi - width, hi);
}

// numSlopes = n slices evenly from slope a to b (the first and last the default plan
// would search), plus an unsearched guard beyond each end that asks for one (every end
// but a finite bound's own slice), so that a feature at a or b has a slice on either
// side and is not pinned there: with two guards, n - 2 searched slices, spacing
// (b - a) / (n - 3). Where a = b the searched slices share one default spacing `unit`
// around it. Too few slices for guards and three searched ones (fewer would space them
// too far apart to place a feature between them): all n searched, spanning [a, b] (one
// at its middle for n = 1), as a hand-set range.
SlopePlan countedPlan(int n, double a, double b, bool guardLow, bool guardHigh, double unit,
                      int T, int S) {
  if (n - int(guardLow) - int(guardHigh) < 3) guardLow = guardHigh = false;
  const int searchedCount = n - int(guardLow) - int(guardHigh);
  if (b - a < 1e-9) {
    a -= 0.5 * unit;
    b += 0.5 * unit;
  }
  const double spacing = searchedCount > 1 ? (b - a) / (searchedCount - 1) : 0.0;
  SlopePlan plan;
  plan.step = spacing;
  plan.origin = (searchedCount > 1 ? a : 0.5 * (a + b)) - (guardLow ? spacing : 0.0);
  for (int k = 0; k < n; ++k) {
    plan.grid.push_back(k);
    plan.slopes.push_back(plan.origin + k * spacing);
    plan.searched.push_back(!((guardLow && k == 0) || (guardHigh && k == n - 1)));
  }
  setBlurTarget(plan, T, S, false);
  return plan;
}

// Bilinear sample of a V x U view at (x, y), clamped to the view (border replicated).
float sample(const float* view, int U, int V, float x, float y) {
  x = std::min(std::max(x, 0.f), U - 1.001f);
  y = std::min(std::max(y, 0.f), V - 1.001f);
  const int x0 = int(x), y0 = int(y);
  const float fx = x - x0, fy = y - y0;
  const float* r0 = view + size_t(y0) * U + x0;
  const float* r1 = r0 + U;
  return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
}

}  // namespace

double sliceSpacing(int T, int S) {
  const int n = std::max(T, S);
  return n > 1 ? 2.0 / (n - 1) : 0.0;
}

bool surveyed(int T, int S) { return std::max(T, S) >= 3; }

double largestSlope(int T, int S, int V, int U) {
  const int n = std::max(T, S);
  if (n < 2) return 0.0;
  const double quarter = std::min(V, U) / (4.0 * (n - 1));
  // Half of the view along each axis with parallax (V for the view rows T, U for the
  // view columns S), the least of them.
  double half = HUGE_VAL;
  if (T > 1) half = std::min(half, V / (2.0 * (T - 1)));
  if (S > 1) half = std::min(half, U / (2.0 * (S - 1)));
  return std::max(quarter, std::min(half, kPaperRange));
}

namespace {

// The keypoint's DoG, w = G(k sigma) - G(sigma), sampled every sigma (enough for a
// statistic of smooth Gaussians) within 3 k sigma: weights and their offsets.
void dogPatch(const cv::KeyPoint& kp, int layers, std::vector<float>& weights,
              std::vector<cv::Point2f>& offsets) {
  const float sigma = std::max(0.5f, kp.size * 0.5f);
  const float k = std::pow(2.f, 1.f / layers), wide = k * sigma;
  const float stepQ = std::max(1.f, sigma);
  const int reach = int(std::ceil(3 * wide / stepQ));
  for (int i = -reach; i <= reach; ++i)
    for (int j = -reach; j <= reach; ++j) {
      const float dx = j * stepQ, dy = i * stepQ, r2 = dx * dx + dy * dy;
      const float g1 = std::exp(-r2 / (2 * sigma * sigma)) / (sigma * sigma);
      const float g2 = std::exp(-r2 / (2 * wide * wide)) / (wide * wide);
      weights.push_back(g2 - g1);
      offsets.emplace_back(dx, dy);
    }
}

// b = sum_q w(q) L(p + q) of one view (premultiplied by alpha where `alpha`: divided by
// the patch's mean weight); false where the patch is mostly invalid (mean weight under
// half the largest).
bool dogResponse(const LightField& lf, int t, int s, cv::Point2f p,
                 const std::vector<float>& weights, const std::vector<cv::Point2f>& offsets,
                 double& b) {
  const float* view = lf.view(t, s);
  const float* alpha =
      lf.weights.empty() ? nullptr : lf.weights[size_t(t) * lf.S + s].ptr<float>();
  double a = 0, total = 0;
  b = 0;
  for (size_t q = 0; q < weights.size(); ++q) {
    const float qx = p.x + offsets[q].x, qy = p.y + offsets[q].y;
    b += weights[q] * sample(view, lf.U, lf.V, qx, qy);
    if (alpha) {
      a += std::abs(weights[q]) * sample(alpha, lf.U, lf.V, qx, qy);
      total += std::abs(weights[q]);
    }
  }
  if (!alpha) return true;
  // Premultiplied values: divide by the patch's mean weight; skip mostly invalid views.
  const double meanWeight = a / total;
  if (!(meanWeight > 0.5 * lf.maxWeight)) return false;
  b /= meanWeight;
  return true;
}

}  // namespace

double viewCoherence(const LightField& lf, const cv::KeyPoint& kp, double slope, int layers) {
  std::vector<float> weights;
  std::vector<cv::Point2f> offsets;
  dogPatch(kp, layers, weights, offsets);
  const double tc = 0.5 * (lf.T - 1), sc = 0.5 * (lf.S - 1);
  double sum = 0, sumSquares = 0;
  int used = 0;
  for (int t = 0; t < lf.T; ++t)
    for (int s = 0; s < lf.S; ++s) {
      const float x = float(kp.pt.x - slope * (s - sc)), y = float(kp.pt.y - slope * (t - tc));
      // Every view must see the feature: where the shifted views no longer overlap, the
      // slice is an average of fewer views, as sharp at a wrong slope as at the right one,
      // and with two views along an axis most such features are ghosts. Patches that
      // reach past a border sample the replicated border.
      if (x < 0 || y < 0 || x > lf.U - 1 || y > lf.V - 1) return -1;
      double b = 0;
      if (!dogResponse(lf, t, s, cv::Point2f(x, y), weights, offsets, b)) continue;
      sum += b;
      sumSquares += b * b;
      ++used;
    }
  if (2 * used < lf.T * lf.S || !(sumSquares > 0)) return -1;
  return sum * sum / (used * sumSquares);
}

double seenCoherence(const LightField& lf, const cv::KeyPoint& kp, double slope, int layers,
                     const std::vector<bool>* onlyViews, int& used) {
  used = 0;
  std::vector<float> weights;
  std::vector<cv::Point2f> offsets;
  dogPatch(kp, layers, weights, offsets);
  // A sample is valid inside the view and, with alpha, where its weight is at least half
  // the largest (values are premultiplied: divided by it there).
  const float floor = 0.5f * float(lf.maxWeight);
  auto alphaAt = [&](int t, int s, cv::Point2f at) {
    return lf.weights.empty()
               ? 1.f
               : sample(lf.weights[size_t(t) * lf.S + s].ptr<float>(), lf.U, lf.V, at.x, at.y);
  };
  auto valid = [&](int t, int s, cv::Point2f at) {
    return at.x >= 0 && at.y >= 0 && at.x <= lf.U - 1 && at.y <= lf.V - 1 &&
           (lf.weights.empty() || alphaAt(t, s, at) >= floor);
  };
  // The views (of onlyViews) that see the keypoint's centre at its slope, validly.
  const double tc = 0.5 * (lf.T - 1), sc = 0.5 * (lf.S - 1);
  std::vector<std::pair<cv::Point, cv::Point2f>> seeing;  // (s, t), position in the view
  for (int t = 0; t < lf.T; ++t)
    for (int s = 0; s < lf.S; ++s) {
      if (onlyViews && !(*onlyViews)[size_t(t) * lf.S + s]) continue;
      const cv::Point2f at(float(kp.pt.x - slope * (s - sc)), float(kp.pt.y - slope * (t - tc)));
      if (valid(t, s, at)) seeing.emplace_back(cv::Point(s, t), at);
    }
  // The patch's samples valid in every one of them (the support they all show), the DoG's
  // weights there less their mean, so that what part of the patch remains sums to 0
  // and a view's mean brightness does not count as agreement.
  std::vector<float> common;
  std::vector<cv::Point2f> commonOffsets;
  for (size_t q = 0; q < weights.size(); ++q) {
    bool inside = true;
    for (const auto& view : seeing)
      inside = inside && valid(view.first.y, view.first.x, view.second + offsets[q]);
    if (!inside) continue;
    common.push_back(weights[q]);
    commonOffsets.push_back(offsets[q]);
  }
  if (common.empty() || seeing.size() < 2) return -1;
  double mean = 0;
  for (float w : common) mean += w;
  mean /= double(common.size());
  double sum = 0, sumSquares = 0;
  for (const auto& [view, position] : seeing) {
    double b = 0;
    for (size_t q = 0; q < common.size(); ++q) {
      const cv::Point2f at = position + commonOffsets[q];
      const float value = sample(lf.view(view.y, view.x), lf.U, lf.V, at.x, at.y);
      b += (common[q] - mean) * value / alphaAt(view.y, view.x, at);
    }
    sum += b;
    sumSquares += b * b;
  }
  used = int(seeing.size());
  if (!(sumSquares > 0)) return -1;
  return sum * sum / (used * sumSquares);
}

// The slopes of `found` whose grid position (spacing `step`) holds at least
// kDensityFactor times the median count over the searched `positions`.
std::vector<double> dense(const std::vector<double>& found, const std::set<long>& positions,
                          double step) {
  std::map<long, int> count;
  for (long k : positions) count[k] = 0;
  for (double m : found) ++count[std::lround(m / step)];
  std::vector<int> counts;
  for (const auto& [k, c] : count) counts.push_back(c);
  if (counts.empty()) return found;
  std::nth_element(counts.begin(), counts.begin() + counts.size() / 2, counts.end());
  const double bar = kDensityFactor * counts[counts.size() / 2];
  std::vector<double> kept;
  for (double m : found)
    if (count[std::lround(m / step)] > bar) kept.push_back(m);
  return kept;
}

// The survey levels (`levels`, finest first, level i decimated finest * 2^i times),
// coarsest to finest: the coarsest over all of `all`, each finer one around the slopes
// the last found and the plane sweep's `textures`.
SlopeSurvey surveyLevels(const std::vector<LightField>& levels, int finest, double unit,
                         const SlopeIntervals& all, const SlopeIntervals& textures,
                         const Parameters& p, double lo, double hi, int batch) {
  SlopeSurvey survey;
  SlopeIntervals candidates = all;
  bool sweepingAll = true;
  int factor = finest << (levels.size() - 1);
  for (int level = int(levels.size()) - 1; level >= 0; --level, factor /= 2) {
    // One pixel of parallax at the outermost view, at the resolution the level's scale
    // space starts from (its first octave doubles the decimated views).
    const double step = unit * factor / 2;
    // The sweep's slopes too: structure a coarser level missed may show at this one.
    SlopeIntervals wanted(candidates);
    for (const auto& [a, b] : textures)
      wanted.emplace_back(a - kCandidateReach * step, b + kCandidateReach * step);
    const std::set<long> positions = positionsIn(merged(wanted), step, lo, hi);
    const std::vector<double> found = surveyLevel(levels[level], factor, positions, step, p, batch);
    ++survey.levels;
    // Where a level searched every slope, keep only slopes with clearly more features
    // than the typical slope: with few views, textures make random extrema at every
    // wrong slope (a few per slope), structure makes many at its own.
    const std::vector<double> kept = sweepingAll ? dense(found, positions, step) : found;
    sweepingAll = sweepingAll && kept.empty();
    survey.slopes = kept;
    survey.spacing = step;
    // Nothing at this level: structure may still be too small for it; the next level
    // searches the same slopes.
    if (kept.empty()) continue;
    SlopeIntervals spans;
    for (double m : kept)
      spans.emplace_back(m - kCandidateReach * step, m + kCandidateReach * step);
    candidates = merged(spans);
  }
  survey.textures = textures;  // searched as they are: fine textures are only there
  return survey;
}

namespace {

// The survey's decimation factors for views of `side` (their shorter side): the finest
// and coarsest levels'; false when the views are too small to survey.
bool surveyLevelsFor(int side, int& finest, int& coarsest) {
  finest = kFinestDecimation;
  while (finest > 2 && side / finest < kFinestSurveyView) finest /= 2;
  if (side / finest < kSmallestSurveyView) return false;
  coarsest = finest;
  while (coarsest < kCoarsestDecimation && side / (coarsest * 2) >= kCoarsestSurveyView)
    coarsest *= 2;
  return true;
}

}  // namespace

double surveyMemoryBytes(const LightField& lf, bool weighted) {
  int finest, coarsest;
  if (!surveyed(lf.T, lf.S) || !surveyLevelsFor(std::min(lf.V, lf.U), finest, coarsest))
    return 0;
  const double planes = weighted ? 2 : 1;  // values (and weights)
  auto viewBytes = [&](int factor) {
    return double(lf.V / factor) * double(lf.U / factor) * sizeof(float) * planes;
  };
  const int sweepFactor = finest / 2;
  double bytes = sweepFactor > 1 ? (lf.T + lf.S - 1) * viewBytes(sweepFactor) : 0;
  for (int factor = finest; factor <= coarsest; factor *= 2)
    bytes += double(lf.T) * lf.S * viewBytes(factor);
  return bytes;
}

SlopeSurvey surveySlopes(const LightField& lf, const Parameters& p, double lo, double hi,
                         int batch) {
  const double unit = sliceSpacing(lf.T, lf.S);
  const double reach = largestSlope(lf.T, lf.S, lf.V, lf.U);
  const int side = std::min(lf.V, lf.U);
  int finest, coarsest;
  if (!surveyLevelsFor(side, finest, coarsest)) return {};  // views too small to survey
  if (!surveyed(lf.T, lf.S)) return {};  // two views: ghosts everywhere (automaticPlan)
  // The plane sweep's light field (decimated half as much as the finest level: fine
  // textures survive there; only the views the sweep reads are kept) and the levels',
  // finest first, each from the last (one pass over the full light field in all).
  const int sweepFactor = finest / 2;
  LightField decimatedForSweep, finestLevel;
  if (sweepFactor > 1)
    decimateTwice(lf, sweepFactor, finest / sweepFactor, sweptViews(lf.T, lf.S),
                  decimatedForSweep, finestLevel);
  else
    finestLevel = decimate(lf, finest);
  const LightField& sweepLevel = sweepFactor > 1 ? decimatedForSweep : lf;
  std::vector<LightField> levels{std::move(finestLevel)};
  for (int f = finest * 2; f <= coarsest; f *= 2) levels.push_back(decimate(levels.back(), 2));
  const SlopeIntervals all{{std::max(lo, -reach), std::min(hi, reach)}};
  // Beyond an end that is the reach (not a bound given), the sweep looks up to one more
  // paper range (or R, where smaller) further, to say whether structure lies there.
  const double lookBeyond = std::min(reach, kPaperRange);
  const bool lowIsReach = -reach > lo, highIsReach = reach < hi;
  const SweptSlopes swept =
      textureSlopes(sweepLevel, sweepFactor, all[0].first, all[0].second, p,
                    lowIsReach ? lookBeyond : 0, highIsReach ? lookBeyond : 0);
  const SlopeIntervals& textures = swept.intervals;
  const bool beyondReach = (swept.beyondLow && lowIsReach) || (swept.beyondHigh && highIsReach);
  SlopeSurvey survey = surveyLevels(levels, finest, unit, all, textures, p, lo, hi, batch);
  if (survey.slopes.empty() && textures.empty()) {
    // Nothing at all, in a light field that need not be blank: decimation weakens fine
    // structure (and noise hides it from the sweep), so look again at a lower contrast
    // threshold, the coherence test still rejecting noise, before falling back to
    // the paper's range.
    Parameters weaker = p;
    weaker.contrastThreshold *= kRetryContrastShare;
    const int runs = survey.levels;
    survey = surveyLevels(levels, finest, unit, all, textures, weaker, lo, hi, batch);
    survey.levels += runs;
  }
  survey.beyondReach = beyondReach;
  return survey;
}

// The slopes the survey says hold structure (before any bound): around each surveyed
// slope with support, and each plane-sweep interval. Views too small to survey: every
// slope up to largestSlope; nothing found: the paper's [-1, 1].
SlopeIntervals occupiedSlopes(const SlopeSurvey& survey, const LightField& lf) {
  const double unit = sliceSpacing(lf.T, lf.S);
  if (survey.levels == 0) {  // views too small to survey: every slope that could be
    const double reach = largestSlope(lf.T, lf.S, lf.V, lf.U) + 0.5 * unit;
    return {{-reach, reach}};
  }
  if (survey.slopes.empty() && survey.textures.empty()) return {{-kPaperRange, kPaperRange}};
  // A surveyed slope m stands for features within the level's half spacing of it; the
  // slices that could hold their extrema lie within half a slice spacing more.
  const double reach = 0.5 * unit + kSurveyUncertainty * survey.spacing;
  std::vector<double> slopes = survey.slopes;
  std::sort(slopes.begin(), slopes.end());
  SlopeIntervals spans;
  for (size_t i = 0; i < slopes.size(); ++i) {
    // A lone surveyed feature, with no other within twice the reach, does not claim
    // slices by itself (one weak survey extremum is as often a fluke)...
    const bool supported = (i > 0 && slopes[i] - slopes[i - 1] <= 2 * reach) ||
                           (i + 1 < slopes.size() && slopes[i + 1] - slopes[i] <= 2 * reach);
    if (supported) spans.emplace_back(slopes[i] - reach, slopes[i] + reach);
  }
  // ...unless no surveyed feature has support and the sweep found nothing: then the
  // lone features are all there is.
  if (spans.empty() && survey.textures.empty())
    for (double m : slopes) spans.emplace_back(m - reach, m + reach);
  // A texture's interval holds its features' slopes; their extrema lie within half a
  // slice spacing more.
  for (const auto& [a, b] : survey.textures) spans.emplace_back(a - 0.5 * unit, b + 0.5 * unit);
  return merged(spans);
}

SlopePlan automaticPlan(const LightField& lf, const Parameters& p, int batch) {
  const double lo = p.firstSlope, hi = p.lastSlope;  // infinite for "automatic"
  const double unit = sliceSpacing(lf.T, lf.S);
  if (unit == 0) {  // a single view: one slice
    SlopePlan plan;
    plan.slopes = {gridOrigin(p)};  // as slopesFor
    plan.grid = {0};
    plan.searched = {true};
    return plan;  // (no interpolation blur: one view, never shifted)
  }
  if (!surveyed(lf.T, lf.S)) {
    // Two views along the longer axis: a slice at a wrong slope averages two views, which
    // a texture matches about as often as at the right slope, so neither the survey nor
    // LiFF can tell slopes far apart. A narrow range, one spacing either side of 0
    // (cut by a bound given; two spacings from a bound given beyond it), as a hand-set one.
    Parameters narrow = p;
    narrow.firstSlope = std::max(-unit, lo);
    narrow.lastSlope = std::min(unit, hi);
    if (!(narrow.firstSlope < narrow.lastSlope))  // the bound given lies beyond it
      std::tie(narrow.firstSlope, narrow.lastSlope) = fromBound(lo, hi, 2 * unit);
    SlopePlan plan = uniformPlan(narrow, lf.T, lf.S);
    setBlurTarget(plan, lf.T, lf.S, false);
    return plan;
  }
  const SlopeSurvey survey = surveySlopes(lf, p, lo, hi, batch);
  const SlopeIntervals occupied = occupiedSlopes(survey, lf);
  // The grid starts at a finite bound the user gave, so that a slice lies on it.
  const double origin = gridOrigin(p);
  std::set<long> searched = positionsIn(occupied, unit, lo, hi, origin);
  if (searched.empty() && (std::isfinite(lo) || std::isfinite(hi))) {
    // Nothing within a finite bound of a half-automatic range (the structure lies beyond
    // it): the paper's range width from the bound, as a hand-set range there would be,
    // whose features beyond are reported at the bound (and warned of).
    searched = positionsIn({fromBound(lo, hi, 2 * kPaperRange)}, unit, lo, hi, origin);
  }
  SlopePlan plan;
  if (p.numSlopes == 0 || searched.empty()) {
    plan = guardedPlan(searched, unit, lf.T, lf.S, origin, lo, hi);
  } else {
    // A guard beyond each end, unless that end is a finite bound's own slice.
    const double a = origin + double(*searched.begin()) * unit;
    const double b = origin + double(*searched.rbegin()) * unit;
    plan = countedPlan(p.numSlopes, a, b, !(a <= lo + 1e-9), !(b >= hi - 1e-9), unit, lf.T, lf.S);
  }
  plan.surveyFoundNothing = survey.levels > 0 && survey.slopes.empty() && survey.textures.empty();
  plan.structureBeyondReach = survey.beyondReach;
  return plan;
}

SlopePlan describingPlan(int T, int S, const std::vector<double>& slopes, double origin) {
  const double unit = sliceSpacing(T, S);
  CV_Assert(unit > 0);
  std::set<long> positions;
  for (double m : slopes) positions.insert(std::lround((m - origin) / unit));
  SlopePlan plan;
  plan.origin = origin;
  plan.step = unit;
  for (long k : positions) {
    plan.grid.push_back(int(k));
    plan.slopes.push_back(origin + double(k) * unit);
    plan.searched.push_back(true);
  }
  setBlurTarget(plan, T, S, true);
  return plan;
}

}  // namespace detail
}  // namespace liff
