// The lookahead controller (context_state.h: Lookahead): how many frames of motion a build's skins
// cover, adapted to the cheapest counted work per frame (deterministic: counts, not time).
#include <algorithm>
#include <cmath>

#include "broad_phase/frame.h"

namespace skinspheres::runtime::broad_phase {

void Frame::AdaptLookahead(double cost, uint32_t frames) {
  double* memory = st.lookahead.rung_cost;
  const double fade = std::pow(kRungFadePerFrame, double(std::max<uint32_t>(frames, 1)));
  const int rung = std::max(st.lookahead.rung, MinRung());
  memory[rung] = memory[rung] > 0.0 ? 0.5 * (memory[rung] + cost) : cost;
  int best = rung;
  double best_cost = memory[rung];
  for (const int r : {rung - 1, rung + 1}) {
    if (r < MinRung() || r >= kRungs) continue;
    memory[r] *= fade;
    const double guess = memory[r] > 0.0 ? memory[r] : 0.9 * memory[rung];
    if (guess < best_cost) {
      best = r;
      best_cost = guess;
    }
  }
  st.lookahead.rung = best;
}

double Frame::ExpiredCacheCost() const {
  const double frames = std::max<uint32_t>(st.cache.age, 1);
  const double cached = kCheckWork * double(n) + kTestWork * double(st.cache.count);
  return (st.cache.build_cost + (frames - 1.0) * cached) / frames;
}

}  // namespace skinspheres::runtime::broad_phase
