// The focal slices' scale spaces a call holds at one time: a window that slides
// along the slope axis, so memory stays bounded whatever the number of slopes.
#pragma once

#include <map>
#include <memory>
#include <vector>

#include "focal_stack.hpp"
#include "light_field.hpp"
#include "scale_space.hpp"
#include "slope_plan.hpp"

namespace liff {
namespace detail {

/// How each slice's scale space is built.
struct ScaleSpaceSettings {
  int layers;          // nOctaveLayers
  double sigma;        // base octave's sigma
  int octaves;         // numOctaves(view size, firstOctave)
  int firstOctave;     // -1: the slice upsampled 2x first; 0: at the views' size
  bool detectionOnly;  // drop the Gaussians no detected keypoint can use
};

/// Owns the scale spaces of the plan's slices that are in use, their focal-slice
/// source and the pool their memory returns to.
/// require() builds what is missing, at most `batch` slices at once (the memory
/// estimate's count); release*() hands memory on to the next slices.
class SliceWindow {
 public:
  /// `renderAhead`: focal slices the source may render ahead in slope order (0 when
  /// slices are wanted in no particular order).
  SliceWindow(const LightField& lf, const SlopePlan& plan, const ScaleSpaceSettings& settings,
              int batch, int renderAhead);

  /// Makes the scale spaces of slices `which` (plan indices) ready.
  void require(const std::vector<int>& which);
  bool holds(int k) const { return spaces_.count(k) > 0; }
  /// The scale space of slice k (which must be held).
  const ScaleSpace& at(int k) const { return *spaces_.at(k); }
  /// The scale spaces of slice k's neighbours on the slope grid (k - 1 and k + 1,
  /// which must be held), or null where the plan has none.
  const ScaleSpace* below(int k) const;
  const ScaleSpace* above(int k) const;
  /// Lets go of every slice below k.
  void releaseBelow(int k);
  /// Lets go of every slice.
  void releaseAll();

 private:
  void build(const std::vector<int>& which);

  const LightField& lf_;
  const SlopePlan& plan_;
  ScaleSpaceSettings settings_;
  int batch_;
  FocalSliceSource source_;
  ScaleSpacePool pool_;
  std::map<int, std::shared_ptr<ScaleSpace>> spaces_;
};

}  // namespace detail
}  // namespace liff
