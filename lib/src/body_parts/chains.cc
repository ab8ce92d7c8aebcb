// Not humanoid: one part per chain of the weighted tree, split at branch points (a branch joint ends
// the chain that reaches it; each of its weighted children starts a new chain), named chain_<k> in
// depth-first order. See split_stages.h and body_parts.h.
#include <string>

#include "split_stages.h"

namespace skinspheres::lib {

void BuildChains(const WeightedSkeleton& ws, BodyParts* out) {
  out->humanoid = false;
  std::vector<int32_t> starts;  // chain start joints, depth-first
  // Above the body: weightless joints with a single weighted child stay -1.
  std::vector<int32_t> stack;
  for (int32_t r = ws.n - 1; r >= 0; --r) {
    if (ws.parent[r] < 0 && ws.sub[r]) stack.push_back(r);
  }
  std::vector<int32_t> body_roots;
  while (!stack.empty()) {
    const int32_t j = stack.back();
    stack.pop_back();
    if (!ws.weighted[j]) {
      if (ws.wchildren[j].size() == 1) {
        stack.push_back(ws.wchildren[j][0]);
        continue;
      }
      if (ws.wchildren[j].size() >= 2) {
        for (auto it = ws.wchildren[j].rbegin(); it != ws.wchildren[j].rend(); ++it) stack.push_back(*it);
        continue;
      }
    }
    body_roots.push_back(j);
  }
  // Depth-first over chains.
  std::vector<int32_t> todo(body_roots.rbegin(), body_roots.rend());
  while (!todo.empty()) {
    const int32_t s = todo.back();
    todo.pop_back();
    const int32_t index = static_cast<int32_t>(out->parts.size());
    BodyPart part;
    part.kind = PartKind::kChain;
    part.name = "chain_" + std::to_string(index);
    int32_t cur = s;
    part.chain.push_back(cur);
    while (ws.wchildren[cur].size() == 1) {
      cur = ws.wchildren[cur][0];
      part.chain.push_back(cur);
    }
    if (ws.wchildren[cur].empty()) {  // on to the weightless tip
      const std::vector<int32_t> tail = ws.MainChain(cur);
      part.chain.insert(part.chain.end(), tail.begin() + 1, tail.end());
    }
    for (int32_t j : part.chain) out->joint_part[j] = index;
    out->parts.push_back(std::move(part));
    for (auto it = ws.wchildren[cur].rbegin(); it != ws.wchildren[cur].rend(); ++it) todo.push_back(*it);
  }
  // Weightless joints inherit their parent's part.
  for (int32_t j = 0; j < ws.n; ++j) {
    if (out->joint_part[j] < 0 && !ws.sub[j] && ws.parent[j] >= 0) out->joint_part[j] = out->joint_part[ws.parent[j]];
  }
  for (size_t i = 0; i < out->parts.size(); ++i)
    FillJoints(ws, out->joint_part, static_cast<int32_t>(i), {}, &out->parts[i]);
}

}  // namespace skinspheres::lib
