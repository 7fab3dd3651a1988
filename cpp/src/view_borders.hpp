// Features at the views' borders: near a border, at a slope far from the scene's, the
// outer views' samples of a point leave the frame, the focal slice there averages fewer
// views, and those are as sharp at a wrong slope as all of them at the right one.
#pragma once

#include "detections.hpp"
#include "light_field.hpp"

namespace liff {
namespace detail {

/// Number of views of `lf` that see the centre-view point `pt` at `slope` (pixels per
/// view step): view (t, s) sees it at pt - slope (s - s_c, t - t_c), which must lie in
/// [0, U - 1] x [0, V - 1].
int viewsSeeing(const LightField& lf, cv::Point2f pt, double slope);

/// Drops the features that not every view sees at their slope unless the views that do
/// see them (validly: alpha) agree: their coherence (seenCoherence, on the samples valid
/// in all of them) at least minCoherence of their number, two at least. A real feature
/// near a border is seen alike by the views that see it (coherence near 1); a ghost
/// there, another slope's structure made sharp by the views that remain, is not (near
/// 1 / n). Features every view sees are kept untested. `layers`: nOctaveLayers (the
/// DoG's scale ratio). docs/RESULTS.md, "Features at the views' borders".
void dropBorderGhosts(const LightField& lf, int layers, Detections& detections);

}  // namespace detail
}  // namespace liff
