// A plane sweep of photo-consistency over slopes: the second cue of the automatic slope
// range, for structure the survey's decimated LiFF levels cannot see (fine textures).
#pragma once

#include <utility>
#include <vector>

#include "light_field.hpp"

namespace liff {
namespace detail {

/// Slope intervals [a, b] (pixels per view step of the light field given), in increasing
/// order and disjoint.
using SlopeIntervals = std::vector<std::pair<double, double>>;

/// The slopes where textured parts of the scene are photo-consistent across the views,
/// found by a multi-baseline plane sweep (Okutomi and Kanade 1993; docs/SLOPES.md): the
/// reference view (T / 2, S / 2) against the outermost views of its row and column, at
/// each slope m = k g of [lo, hi] (g: half a pixel of parallax at the farthest of them),
/// absolute differences (each view and the reference interpolated alike) summed over a
/// 3 x 3 window. A pixel votes for its best slope when that costs under kConsistency
/// times its mean cost over all slopes, its window's texture is well above that best's
/// residual (a flat region never votes), and its |DoG| reaches `minResponse` (LiFF's
/// pre-test threshold: structure LiFF could find). Slopes whose votes cover at least
/// kMinVoteShare of the view are returned, each as [m - g / 2, m + g / 2], merged where
/// they touch; one slope beyond each end is swept, its votes not counted (a layer beyond
/// the range would vote for the end slope). Outer views whose mean weight (alpha) is
/// under half the largest are passed over for the outermost usable ones. `lf` may be decimated: slopes are in its own pixels per view step.
SlopeIntervals sweepSlopes(const LightField& lf, double lo, double hi, float minResponse);

/// The views sweepSlopes reads (T * S flags, LightField layout): the reference view's
/// row and column, T / 2 and S / 2; the others may be left empty.
std::vector<bool> sweptViews(int T, int S);

}  // namespace detail
}  // namespace liff
