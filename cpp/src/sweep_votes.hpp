// The plane sweep's votes (slope_sweep.hpp): per pixel of the reference view its best
// slope, counted per cell of the view and slope, and the slopes that count: layers, and
// small features whose votes gather in one place and whose views agree.
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <vector>


namespace liff {
namespace detail {

/// Per pixel of the reference view, over the slopes swept: the least window cost and its
/// slope index, and the sum and number of window costs.
struct Votes {
  cv::Mat best, index, sum, count;  // CV_32F, CV_32S, CV_32F, CV_32S
  /// Allocated, not yet set: clear() sets rows to no votes.
  explicit Votes(cv::Size size);
  /// Rows [rowBegin, rowEnd) to no votes: best +inf, index -1, sum and count 0.
  void clear(int rowBegin, int rowEnd);
  /// Adds the votes `later` (of slopes after this one's, their index shifted by
  /// `indexOffset`) on rows [rowBegin, rowEnd): sums and counts added, the best kept
  /// where it is not beaten (ties go to the earlier slopes, as within one sweep).
  void merge(const Votes& later, int indexOffset, int rowBegin, int rowEnd);
};

/// What votes and where, for the n slopes swept: a pixel that saw at least `minCount`
/// slopes votes for its best when (a) that best is under kConsistency times its mean
/// cost, (b) its window's texture (`texture`) is kTextureToResidual times that best per
/// compared view, and (c) its |DoG| (`response`) reaches `minResponse` (LiFF's pre-test);
/// votes whose |DoG| reaches `featureResponse` (LiFF's detection threshold) are "strong".
/// Counted per cell of kVoteCell pixels, with each cell's strongest strong vote per slope
/// (Mats, one row per cell, one column per slope: the working memory keeps them from call
/// to call).
struct VoteCounts {
  int n = 0, cellsX = 0, cellsY = 0;
  std::vector<int> perSlope;   // all votes per slope
  cv::Mat all, strong;         // CV_32S, row cy * cellsX + cx
  cv::Mat strongestResponse;   // CV_32F, of the strong votes
  cv::Mat strongestAt;         // CV_32SC2 (x, y)
  double viewPixels = 0;

  /// A layer: votes at slope k cover kMinVoteShare of the view.
  bool layer(int k) const;
  /// The strongest strong votes of slope k over all cells, at most `count`, strongest first.
  std::vector<cv::Point> strongestVotes(int k, int count) const;
};
/// Votes for the slopes `skipped` are not counted (only the rest are looked at).
VoteCounts countVotes(const Votes& votes, int n, const cv::Mat& texture, const cv::Mat& response,
                      int compared, int minCount, float minResponse, float featureResponse,
                      cv::Range skipped = cv::Range(0, 0));

/// Per slope, its strongest cluster: the strong votes of slope k and its neighbours in
/// the block of 2 x 2 cells where slope k holds the most of the three and the three
/// hold at least kMinClusterVotes (0 where there is none), and that block's strongest
/// vote at slope k; only for the slopes `wanted` (n flags) where given.
struct Clusters {
  std::vector<int> votes;
  std::vector<cv::Point> at;
};
Clusters findClusters(const VoteCounts& counts, const std::vector<char>* wanted = nullptr);

/// Whether the views agree at `point` (reference-view pixels) at slope index k.
using Agreement = std::function<bool(cv::Point point, int k)>;

/// Whether slope k counts: a layer, or a cluster not within kClusterLayerGap slopes of a
/// layer (that layer's votes spread over slopes) whose views agree at its strongest vote
/// (a repeated pattern matches the outermost views at an alias slope too).
bool slopeCounts(const VoteCounts& counts, const Clusters& clusters, int k,
                 const Agreement& agree);

/// Whether structure lies at slope k (one swept beyond an end of the range): a layer or
/// a cluster there whose views agree at two of its kBeyondChecks strongest votes (a
/// repeated pattern's alias there does not: no warning of structure that is not there).
bool structureAt(const VoteCounts& counts, const Clusters& clusters, int k,
                 const Agreement& agree);

}  // namespace detail
}  // namespace liff
