// The automatic slope range: which focal slices a light field needs, found from its
// pixels by a coarse-to-fine pre-pass (docs/SLOPES.md has the method and its maths).
#pragma once

#include <liff/liff.hpp>
#include <liff/parameters.hpp>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "light_field.hpp"
#include "slope_plan.hpp"
#include "slope_sweep.hpp"

namespace liff {
namespace detail {

/// Slice spacing for T x S views: one pixel of parallax at the outermost view,
/// 2 / (max(T, S) - 1) pixels per view step (0 for a single view).
double sliceSpacing(int T, int S);

/// Whether the automatic range comes from the survey: three or more views along the
/// longer axis (one view has one slice; two get a fixed narrow range, automaticPlan).
bool surveyed(int T, int S);

/// Largest |slope| the automatic range considers: min(V, U) / (4 (max(T, S) - 1)), where
/// the two outermost views differ by a quarter of the smaller view side, beyond which
/// too little of the views overlaps to focus anything; where that is under the paper's
/// [-1, 1] (long rows of views, small views), up to 1 while the outermost views along each
/// axis with parallax still differ by at most half the view along it (side / (2 (n - 1))),
/// so that the paper's range is considered while the central half of every view is seen
/// by all views.
double largestSlope(int T, int S, int V, int U);

/// Share of the views' energy that adds up coherently at a keypoint: with b_v the
/// DoG response (at the keypoint's scale) of view v sampled where the keypoint's
/// slope puts it, kappa = (sum_v b_v)^2 / (n sum_v b_v^2), in [0, 1]. A real feature
/// seen alike by the views gives about 1; a ghost (one view's copy of a feature that
/// lies at another slope) or noise about 1 / n. -1 when a view does not see the keypoint
/// (its shifted position falls outside it: there the slice averages fewer views and is
/// as sharp at a wrong slope); views whose patch is mostly invalid (alpha) are left out,
/// and -1 when fewer than half remain. Patches reaching past a border sample the
/// replicated border.
/// `keypoint` is in `lf`'s pixels and its slope in `lf`'s pixels per view step.
double viewCoherence(const LightField& lf, const cv::KeyPoint& keypoint, double slope, int layers);

/// The coherence (as viewCoherence) of the views that see the keypoint's centre at its
/// slope, validly (inside the view; with alpha, a weight of at least half the largest),
/// of `onlyViews` (T * S flags in LightField layout, where given: the others may be
/// empty), over the part of the DoG's patch valid in every one of them, its weights less
/// their mean there (zero sum: brightness alone does not agree), premultiplied values
/// divided by their weight. `used`: the views summed. -1 with fewer than two, or no
/// common support. How the views that see a feature near a border agree
/// (view_borders.hpp), and the plane sweep's check of its clusters.
double seenCoherence(const LightField& lf, const cv::KeyPoint& keypoint, double slope, int layers,
                     const std::vector<bool>* onlyViews, int& used);

/// The least coherence of a feature of n views, halfway between 1 and the coherence an
/// extremum of noise or texture picked among n views reaches, z^2 / (n + z^2) for a
/// z = 5 sigma extreme: (1 + 25 / (n + 25)) / 2.
inline double minCoherence(int views) { return 0.5 * (1 + 25.0 / (views + 25.0)); }

/// Bytes of the decimated light fields surveySlopes makes for `lf` (0 when it does not
/// survey): the plane sweep's views and every level's. They are freed when the survey
/// ends, but the working memory keeps them for the next call's survey (working_memory.hpp),
/// so they count through the whole call (MemoryEstimate::surveyBytes).
/// `weighted`: the light field carries alpha weights (decimated alongside).
double surveyMemoryBytes(const LightField& lf, bool weighted);

/// What the pre-pass found: the slopes of the coherent features of its finest level
/// (full-resolution pixels per view step) and that level's slice spacing.
struct SlopeSurvey {
  std::vector<double> slopes;
  double spacing = 0;
  int levels = 0;  // decimation levels run (0: views too small, nothing run)
  /// Slope intervals of the plane sweep (sweepSlopes): textured structure, also where it
  /// is too fine for the decimated levels.
  SlopeIntervals textures;
  /// The sweep saw structure at or beyond +-largestSlope (an end of the range it swept
  /// that is not a finite bound given): slopes the automatic range does not consider.
  bool beyondReach = false;
};

/// Runs the pre-pass: LiFF's own detection (parameters `p`) on the light field
/// decimated 4 times (2 where that leaves views under 64 pixels;
/// views under 32 pixels are not surveyed), then 8 and 16 times while views keep 40
/// pixels; the coarsest level over all slopes within [lo, hi] and +-largestSlope, each
/// finer one only around the slopes of the coherent features of the last and the plane
/// sweep's intervals (sweepSlopes, on the light field decimated half as much as the
/// finest level: fine textures); features below minCoherence are dropped as ghosts or
/// noise. When neither finds anything, the levels run again at half the contrast
/// threshold (noise and decimation hide weak structure).
SlopeSurvey surveySlopes(const LightField& lf, const Parameters& p, double lo, double hi,
                         int batch);

/// The automatic plan: the slices on the grid o + k * sliceSpacing (k whole; o the finite
/// bound where one is given, else 0) within half a spacing, plus the survey's
/// uncertainty, of a surveyed slope or within half a spacing of a sweep interval, each
/// searched, and their grid neighbours as
/// unsearched guards; gaps between surveyed slopes are skipped. With numSlopes > 0,
/// that many slices evenly from the first to the last slope the default would search,
/// plus one unsearched guard beyond each end that is not a finite bound's own slice (so
/// no feature is pinned there), when at least three slices remain searched.
/// No slice lies beyond a finite bound [lo, hi]; a slice at it is searched, as the ends
/// of a hand-set range are. When the survey finds nothing (a blank light field), the
/// plan spans the paper's [-1, 1] within the bounds; when nothing it finds lies within a
/// finite bound, the paper's range width from that bound; views too small to survey (under
/// 32 pixels) get every slope up to largestSlope (rounded outward to the grid). With
/// two views along the longer axis (stereo pairs, 2 x 2), where slopes far from the
/// truth focus textures as well as the truth, no survey: [-2, 2] (one spacing either
/// side of 0) cut by the bound given, or two spacings from a bound beyond it, as a
/// hand-set range.
SlopePlan automaticPlan(const LightField& lf, const Parameters& p, int batch);

/// compute() with an automatic range and several views: the slices of the grid
/// origin + k * sliceSpacing (origin: the finite bound of a half-automatic range, else
/// 0) nearest each of `slopes` (the given keypoints'), the slices detection describes
/// them on.
SlopePlan describingPlan(int T, int S, const std::vector<double>& slopes, double origin = 0);

}  // namespace detail
}  // namespace liff
