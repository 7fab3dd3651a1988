#include "sweep_votes.hpp"

#include <algorithm>
#include <limits>
#include <utility>

#include "profile.hpp"

namespace liff {
namespace detail {
namespace {

/// A pixel votes when its best slope costs less than this share of its mean cost: a
/// texture costs its contrast at wrong slopes and only noise at its own; a flat region
/// costs noise everywhere (ratio near 1); a window straddling an occlusion edge about
/// half its mean at either layer's slope.
constexpr float kConsistency = 0.4f;
/// ...and when its window's own texture (summed absolute differences of neighbouring
/// pixels) is this many times its best cost per view: otherwise the low best is that
/// of a flat window (whose mean cost is raised by structure that crosses it at other
/// slopes), not a match. Noise alone gives about 2 (two differences per pixel against
/// one per view); 3 keeps textures only a little above the noise of one view.
constexpr float kTextureToResidual = 3.f;
/// A slope counts when its votes cover this share of the view's pixels (a 9 x 9 patch of
/// a 128 x 128 view): a layer large enough to hold features, not scattered edge votes...
constexpr double kMinVoteShare = 0.005;
/// ...or when votes where LiFF's detection threshold is reached gather in one place: a
/// small feature seen alike by the views, however small its share of a large view. Votes
/// are counted per cell of kVoteCell x kVoteCell pixels; a slope counts where, in a block
/// of 2 x 2 cells, it holds the most of its neighbouring slopes' votes and those three
/// slopes (1.5 pixels of parallax at the farthest view) hold at least kMinClusterVotes: a
/// 4 x 4 patch of the block's 16 x 16, which scattered edge and noise votes (a few per
/// slope in a whole view) do not reach...
constexpr int kVoteCell = 8;
constexpr int kMinClusterVotes = 16;
/// ...unless a slope within this many sweep slopes (one pixel of parallax at the farthest
/// view) counts by its share: such a cluster is that layer's votes spread over slopes.
constexpr int kClusterLayerGap = 2;
/// Votes checked for agreement of the views at a slope beyond an end of the range, and
/// how many of them must agree: structure holds several strong votes that agree, a
/// repeated pattern's alias at most a chance one.
constexpr int kBeyondChecks = 3;
constexpr int kBeyondAgreeing = 2;
/// Rows of cells counted per task.
constexpr int kCellRowsPerTask = 2;

}  // namespace

Votes::Votes(cv::Size size)
    : best(size, CV_32F), index(size, CV_32S), sum(size, CV_32F), count(size, CV_32S) {}

void Votes::clear(int rowBegin, int rowEnd) {
  const cv::Range rows(rowBegin, rowEnd);
  best.rowRange(rows).setTo(std::numeric_limits<float>::infinity());
  index.rowRange(rows).setTo(-1);
  sum.rowRange(rows).setTo(0);
  count.rowRange(rows).setTo(0);
}

void Votes::merge(const Votes& later, int indexOffset, int rowBegin, int rowEnd) {
  const cv::Range rows(rowBegin, rowEnd);
  cv::Mat sumRows = sum.rowRange(rows), countRows = count.rowRange(rows);
  sumRows += later.sum.rowRange(rows);
  countRows += later.count.rowRange(rows);
  const cv::Mat better = later.best.rowRange(rows) < best.rowRange(rows);
  later.best.rowRange(rows).copyTo(best.rowRange(rows), better);
  if (indexOffset == 0) {
    later.index.rowRange(rows).copyTo(index.rowRange(rows), better);
    return;
  }
  const cv::Mat shifted = later.index.rowRange(rows) + indexOffset;
  shifted.copyTo(index.rowRange(rows), better);
}

bool VoteCounts::layer(int k) const {
  return k >= 0 && k < n && perSlope[k] >= kMinVoteShare * viewPixels;
}

std::vector<cv::Point> VoteCounts::strongestVotes(int k, int count) const {
  std::vector<std::pair<float, cv::Point>> votes;
  for (int c = 0; c < strongestResponse.rows; ++c) {
    const float response = strongestResponse.at<float>(c, k);
    if (response > 0) votes.emplace_back(response, cv::Point(strongestAt.at<cv::Vec2i>(c, k)));
  }
  const size_t kept = std::min(votes.size(), size_t(count));
  std::partial_sort(votes.begin(), votes.begin() + kept, votes.end(),
                    [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<cv::Point> points;
  for (size_t i = 0; i < kept; ++i) points.push_back(votes[i].second);
  return points;
}

VoteCounts countVotes(const Votes& votes, int n, const cv::Mat& texture, const cv::Mat& response,
                      int compared, int minCount, float minResponse, float featureResponse,
                      cv::Range skipped) {
  VoteCounts counts;
  const int V = votes.best.rows, U = votes.best.cols;
  counts.n = n;
  counts.cellsX = (U + kVoteCell - 1) / kVoteCell;
  counts.cellsY = (V + kVoteCell - 1) / kVoteCell;
  counts.viewPixels = double(V) * U;
  const int cells = counts.cellsX * counts.cellsY;
  counts.all = cv::Mat::zeros(cells, n, CV_32S);
  counts.strong = cv::Mat::zeros(cells, n, CV_32S);
  counts.strongestResponse = cv::Mat::zeros(cells, n, CV_32F);
  counts.strongestAt = cv::Mat::zeros(cells, n, CV_32SC2);
  const int tasks = (counts.cellsY + kCellRowsPerTask - 1) / kCellRowsPerTask;
  parallelFor("survey plane sweep", cv::Range(0, tasks), [&](const cv::Range& range) {
    const int yBegin = range.start * kCellRowsPerTask * kVoteCell;
    const int yEnd = std::min(V, range.end * kCellRowsPerTask * kVoteCell);
    for (int y = yBegin; y < yEnd; ++y)
      for (int x = 0; x < U; ++x) {
        const int count = votes.count.at<int>(y, x);
        if (count < minCount) continue;
        const int k = votes.index.at<int>(y, x);
        if (k >= skipped.start && k < skipped.end) continue;
        const float best = votes.best.at<float>(y, x), dog = response.at<float>(y, x);
        if (!(best < kConsistency * votes.sum.at<float>(y, x) / count &&
              texture.at<float>(y, x) >= kTextureToResidual * best / float(compared) &&
              dog >= minResponse))
          continue;
        const int cell = (y / kVoteCell) * counts.cellsX + x / kVoteCell;
        ++counts.all.at<int>(cell, k);
        if (dog < featureResponse) continue;
        ++counts.strong.at<int>(cell, k);
        if (dog > counts.strongestResponse.at<float>(cell, k)) {
          counts.strongestResponse.at<float>(cell, k) = dog;
          counts.strongestAt.at<cv::Vec2i>(cell, k) = cv::Vec2i(x, y);
        }
      }
  });
  counts.perSlope.assign(n, 0);
  for (int c = 0; c < cells; ++c) {
    const int* row = counts.all.ptr<int>(c);
    for (int k = 0; k < n; ++k) counts.perSlope[k] += row[k];
  }
  return counts;
}

Clusters findClusters(const VoteCounts& counts, const std::vector<char>* wanted) {
  const int n = counts.n, cellsX = counts.cellsX, cellsY = counts.cellsY;
  // Blocks of 2 x 2 cells (one cell where the view has a single row or column of them);
  // each row of blocks by one task, its best per slope kept apart, then merged in row
  // order (the first of equal clusters kept, as one loop over the rows would).
  const int blockRows = std::max(2, cellsY) - 1, blockColumns = std::max(2, cellsX) - 1;
  auto want = [&](int k) { return k >= 0 && k < n && (!wanted || (*wanted)[k]); };
  std::vector<Clusters> rows(blockRows);
  std::vector<std::vector<float>> rowStrongest(blockRows);
  parallelFor("survey plane sweep", cv::Range(0, blockRows), [&](const cv::Range& range) {
    std::vector<int> block(n);
    for (int cy = range.start; cy < range.end; ++cy) {
      Clusters& found = rows[cy];
      std::vector<float>& strongest = rowStrongest[cy];
      found.votes.assign(n, 0);
      found.at.assign(n, cv::Point());
      strongest.assign(n, 0.f);
      for (int cx = 0; cx < blockColumns; ++cx) {
        std::fill(block.begin(), block.end(), 0);
        for (int dy = 0; dy < std::min(2, cellsY); ++dy)
          for (int dx = 0; dx < std::min(2, cellsX); ++dx) {
            const int* counted = counts.strong.ptr<int>((cy + dy) * cellsX + cx + dx);
            for (int k = 0; k < n; ++k)
              if (want(k) || want(k - 1) || want(k + 1)) block[k] += counted[k];
          }
        for (int k = 0; k < n; ++k) {
          if (!want(k)) continue;
          const int below = k > 0 ? block[k - 1] : 0, above = k + 1 < n ? block[k + 1] : 0;
          const int sum = below + block[k] + above;
          if (block[k] < below || block[k] < above || sum < kMinClusterVotes ||
              sum <= found.votes[k])
            continue;
          found.votes[k] = sum;
          strongest[k] = 0.f;
          for (int dy = 0; dy < std::min(2, cellsY); ++dy)
            for (int dx = 0; dx < std::min(2, cellsX); ++dx) {
              const int cell = (cy + dy) * cellsX + cx + dx;
              if (counts.strongestResponse.at<float>(cell, k) > strongest[k]) {
                strongest[k] = counts.strongestResponse.at<float>(cell, k);
                found.at[k] = cv::Point(counts.strongestAt.at<cv::Vec2i>(cell, k));
              }
            }
        }
      }
    }
  });
  Clusters clusters;
  clusters.votes.assign(n, 0);
  clusters.at.assign(n, cv::Point());
  for (const Clusters& row : rows)
    for (int k = 0; k < n; ++k)
      if (row.votes[k] > clusters.votes[k]) {
        clusters.votes[k] = row.votes[k];
        clusters.at[k] = row.at[k];
      }
  return clusters;
}

bool slopeCounts(const VoteCounts& counts, const Clusters& clusters, int k,
                 const Agreement& agree) {
  if (counts.layer(k)) return true;
  if (clusters.votes[k] == 0) return false;
  for (int d = 1; d <= kClusterLayerGap; ++d)
    if (counts.layer(k - d) || counts.layer(k + d)) return false;  // that layer's own spread
  return agree(clusters.at[k], k);
}

bool structureAt(const VoteCounts& counts, const Clusters& clusters, int k,
                 const Agreement& agree) {
  if (!counts.layer(k) && clusters.votes[k] == 0) return false;
  int agreeing = 0;
  for (const cv::Point& point : counts.strongestVotes(k, kBeyondChecks))
    if (agree(point, k) && ++agreeing == kBeyondAgreeing) return true;
  return false;
}

}  // namespace detail
}  // namespace liff
