// The tightening pass's state: construction, each sphere's vertices and holding radius, dropping
// empty spheres. See tightener.h.
#include "tightener.h"

#include <algorithm>

#include "skinspheres/lib/geometry/fibonacci_directions.h"

namespace skinspheres::lib {

Tightener::Tightener(const RawCharacter& ch, const TightenSettings& settings, std::vector<TightSphere>& spheres)
    : ch_(ch), st_(settings), sp_(spheres), unique_(ch.triangles, ch.vertex_count()) {
  // Budget-only (step 3b alone) reads no distance: the field, most of the pass's set-up, is skipped.
  if (!settings.budget_only) field_ = DistanceField::Build(ch.positions_rest, ch.triangles, settings.field_resolution);
  unit_ = FibonacciDirections(std::max(1, settings.samples));
  height_ = BodyHeight(ch.positions_rest);
  pts_.resize(sp_.size());
  for (size_t s = 0; s < sp_.size(); ++s) Refresh(s);
}

void Tightener::Refresh(size_t s) {
  pts_[s] = Points(sp_[s].triangles);
  // The unpadded holding radius: the fitter holds the spheres it keeps again, with the pad.
  sp_[s].radius = pts_[s].empty() ? 0.0f : HoldingRadius(pts_[s], sp_[s].center, 0.0);
}

std::vector<Eigen::Vector3f> Tightener::Points(const std::vector<uint32_t>& tris) {
  return unique_.Positions(ch_.positions_rest, tris);
}

int Tightener::DropEmpty() {
  size_t out = 0;
  for (size_t s = 0; s < sp_.size(); ++s) {
    if (sp_[s].triangles.empty()) continue;
    if (out != s) {
      sp_[out] = std::move(sp_[s]);
      pts_[out] = std::move(pts_[s]);
    }
    ++out;
  }
  const int dropped = static_cast<int>(sp_.size() - out);
  sp_.resize(out);
  pts_.resize(out);
  return dropped;
}

void Tightener::Finish() {
  for (auto& s : sp_) std::sort(s.triangles.begin(), s.triangles.end());
}

}  // namespace skinspheres::lib
