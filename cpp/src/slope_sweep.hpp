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

/// What the sweep found: its slope intervals, and whether the slope swept beyond each
/// end of the range (votes not counted in the intervals) gathered enough votes to count:
/// structure at or beyond that end.
struct SweptSlopes {
  SlopeIntervals intervals;
  bool beyondLow = false, beyondHigh = false;
};

/// The slopes where textured parts of the scene are photo-consistent across the views,
/// found by a multi-baseline plane sweep (Okutomi and Kanade 1993; docs/SLOPES.md): the
/// reference view (T / 2, S / 2) against the outermost views of its row and column, at
/// each slope m = k g of [lo, hi] (g: half a pixel of parallax at the farthest of them),
/// absolute differences (each view and the reference interpolated alike) summed over a
/// 3 x 3 window. A pixel votes for its best slope when that costs under kConsistency
/// times its mean cost over all slopes, its window's texture is well above that best's
/// residual (a flat region never votes), and its |DoG| reaches `minResponse` (LiFF's
/// pre-test threshold: structure LiFF could find). Slopes whose votes cover at least
/// kMinVoteShare of the view, or whose votes with a |DoG| of at least `featureResponse`
/// (LiFF's detection threshold) gather in one place (a small feature: kMinClusterVotes
/// in a 16 x 16 block, with its neighbouring slopes; not beside a slope counted by its
/// share), are returned, each as
/// [m - g / 2, m + g / 2], merged where they touch. Beyond each end the slopes up to
/// `beyondLow` below lo and `beyondHigh` above hi (at least one slope) are swept too, their
/// votes not counted in the intervals (a layer beyond the range would vote for the end
/// slope) but reported (SweptSlopes::beyondLow, beyondHigh) where a layer or cluster
/// there is seen alike by the reference's row and column (seenCoherence: not a repeated
/// pattern's alias). Outer views whose mean weight (alpha) is
/// under half the largest are passed over for the outermost usable ones. `lf` may be decimated: slopes are in its own pixels per view step.
SweptSlopes sweepSlopes(const LightField& lf, double lo, double hi, float minResponse,
                        float featureResponse, double beyondLow = 0, double beyondHigh = 0);

/// The views sweepSlopes reads (T * S flags, LightField layout): the reference view's
/// row and column, T / 2 and S / 2; the others may be left empty.
std::vector<bool> sweptViews(int T, int S);

}  // namespace detail
}  // namespace liff
