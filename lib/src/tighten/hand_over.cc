// Step 2 (and 5) of the tightening pass: a triangle on a sphere's rim that another sphere of its part
// already holds whole moves there; the receiver does not grow, the giver may shrink. See
// sphere_tightener.h.
#include <algorithm>

#include "tightener.h"

namespace skinspheres::lib {

int Tightener::HandOver() {
  std::vector<size_t> order(sp_.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return sp_[a].radius > sp_[b].radius; });
  int moved = 0;
  std::vector<uint32_t> keep;
  for (size_t s : order) {
    if (sp_[s].triangles.empty()) continue;
    keep.clear();
    const float rim2 = kRimFraction * kRimFraction * sp_[s].radius * sp_[s].radius;
    for (uint32_t t : sp_[s].triangles) {
      const Eigen::Vector3f* v[3] = {&ch_.positions_rest[ch_.triangles[t][0]], &ch_.positions_rest[ch_.triangles[t][1]],
                                     &ch_.positions_rest[ch_.triangles[t][2]]};
      float need2 = 0.0f;
      for (const auto* p : v) need2 = std::max(need2, (*p - sp_[s].center).squaredNorm());
      long dest = -1;
      if (need2 > rim2) {
        for (size_t o = 0; o < sp_.size() && dest < 0; ++o) {
          if (o == s || sp_[o].part != sp_[s].part || sp_[o].triangles.empty()) continue;
          const float r2 = sp_[o].radius * sp_[o].radius;
          bool inside = true;
          for (const auto* p : v) inside = inside && (*p - sp_[o].center).squaredNorm() <= r2;
          if (inside) dest = static_cast<long>(o);
        }
      }
      if (dest >= 0) {
        sp_[dest].triangles.push_back(t);
        ++moved;
      } else {
        keep.push_back(t);
      }
    }
    sp_[s].triangles.swap(keep);
    Refresh(s);  // at once: later spheres must not hand triangles back to its old, larger radius
  }
  // Radii become the holding radii of what each sphere now owns: a receiving sphere held its new
  // triangles already, so it does not grow; a giving one may shrink.
  for (size_t s = 0; s < sp_.size(); ++s) Refresh(s);
  return moved;
}

}  // namespace skinspheres::lib
