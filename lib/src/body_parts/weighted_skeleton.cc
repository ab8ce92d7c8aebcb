// The skeleton as the body-part split sees it: the dominant joint of every vertex and triangle, the
// weighted tree (joints whose subtree carries weight) and per-subtree point statistics. See
// split_stages.h.
#include <algorithm>
#include <utility>

#include "split_stages.h"

namespace skinspheres::lib {
namespace {

// The tree and the rest-pose joint positions.
void BuildTopology(const RawCharacter& ch, WeightedSkeleton* ws) {
  const auto& sk = ch.skeleton;
  ws->n = static_cast<int32_t>(sk.size());
  const int32_t n = ws->n;
  ws->parent = sk.parents;
  ws->children.assign(n, {});
  for (int32_t j = 0; j < n; ++j) {
    if (ws->parent[j] >= 0) ws->children[ws->parent[j]].push_back(j);
  }
  std::vector<Mat4f> world(n);
  sk.RestWorld(world);
  ws->jpos.resize(n);
  for (int32_t j = 0; j < n; ++j) ws->jpos[j] = world[j].topRightCorner<3, 1>().cast<double>();
}

// Vertex: the joint of largest weight; triangle: largest summed weight over its 3 vertices.
// Ties -> smallest joint index.
void DominantJoints(const RawCharacter& ch, WeightedSkeleton* ws, std::vector<int32_t>* triangle_joint) {
  const size_t nv = ch.positions_rest.size();
  const auto& skin = ch.skin;
  const bool has_skin = skin.vertex_count() > 0;
  ws->vertex_joint.assign(nv, -1);
  std::vector<std::pair<int32_t, float>> acc;
  auto add = [&acc](int32_t joint, float w) {
    for (auto& e : acc) {
      if (e.first == joint) {
        e.second += w;
        return;
      }
    }
    acc.emplace_back(joint, w);
  };
  auto best_of = [&acc]() {
    int32_t best = -1;
    float best_w = 0.0f;
    for (const auto& e : acc) {
      if (e.second <= 0.0f) continue;
      if (best < 0 || e.second > best_w || (e.second == best_w && e.first < best)) {
        best = e.first;
        best_w = e.second;
      }
    }
    return best;
  };
  auto add_vertex = [&](size_t v) {
    for (uint32_t i = skin.influence_offsets[v]; i < skin.influence_offsets[v + 1]; ++i) {
      add(skin.binds[skin.influence_binds[i]].joint, skin.influence_weights[i]);
    }
  };
  if (has_skin) {
    for (size_t v = 0; v < nv; ++v) {
      acc.clear();
      add_vertex(v);
      ws->vertex_joint[v] = best_of();
    }
  }
  // Fallback joint for weightless triangles: their mesh's rigid joint, else the first root.
  std::vector<int32_t> tri_fallback(ch.triangles.size(), 0);
  for (const MeshRange& m : ch.meshes) {
    if (m.rigid_joint < 0) continue;
    const size_t end = std::min<size_t>(ch.triangles.size(), size_t{m.first_triangle} + m.triangle_count);
    for (size_t t = m.first_triangle; t < end; ++t) tri_fallback[t] = m.rigid_joint;
  }
  triangle_joint->assign(ch.triangles.size(), 0);
  for (size_t t = 0; t < ch.triangles.size(); ++t) {
    acc.clear();
    if (has_skin) {
      for (int k = 0; k < 3; ++k) add_vertex(static_cast<size_t>(ch.triangles[t][k]));
    }
    const int32_t best = best_of();
    (*triangle_joint)[t] = best >= 0 ? best : tri_fallback[t];
  }
}

// The weighted joints (dominant joint of a vertex or triangle; every joint of a bare skeleton),
// their ancestors (sub), and the subtree statistics the humanoid search scores with.
void BuildWeightedTree(const RawCharacter& ch, std::span<const int32_t> triangle_joint, WeightedSkeleton* ws) {
  const int32_t n = ws->n;
  ws->weighted.assign(n, false);
  for (int32_t j : ws->vertex_joint) {
    if (j >= 0) ws->weighted[j] = true;
  }
  for (int32_t j : triangle_joint) ws->weighted[j] = true;
  if (std::none_of(ws->weighted.begin(), ws->weighted.end(), [](bool b) { return b; })) {
    ws->weighted.assign(n, true);  // a bare skeleton: every joint counts
  }
  ws->sub = ws->weighted;
  for (int32_t j = n - 1; j >= 0; --j) {
    if (ws->sub[j] && ws->parent[j] >= 0) ws->sub[ws->parent[j]] = true;
  }
  ws->wchildren.assign(n, {});
  for (int32_t j = 0; j < n; ++j) {
    for (int32_t c : ws->children[j]) {
      if (ws->sub[c]) ws->wchildren[j].push_back(c);
    }
  }
  // Subtree point statistics: vertices by their dominant joint plus joint positions.
  ws->own.assign(n, PointStats{});
  for (size_t v = 0; v < ws->vertex_joint.size(); ++v) {
    const int32_t j = ws->vertex_joint[v];
    if (j < 0) continue;
    ws->own[j].sum += ch.positions_rest[v].cast<double>();
    ws->own[j].count += 1.0;
  }
  ws->own_vertices.assign(n, 0.0);
  for (int32_t j = 0; j < n; ++j) {
    ws->own_vertices[j] = ws->own[j].count;
    ws->own[j].sum += ws->jpos[j];
    ws->own[j].count += 1.0;
  }
  ws->subtree = ws->own;
  ws->subtree_vertices = ws->own_vertices;
  ws->subtree_weighted.assign(n, 0);
  for (int32_t j = 0; j < n; ++j) ws->subtree_weighted[j] = ws->weighted[j] ? 1 : 0;
  for (int32_t j = n - 1; j >= 0; --j) {
    const int32_t p = ws->parent[j];
    if (p < 0) continue;
    ws->subtree[p].sum += ws->subtree[j].sum;
    ws->subtree[p].count += ws->subtree[j].count;
    ws->subtree_vertices[p] += ws->subtree_vertices[j];
    ws->subtree_weighted[p] += ws->subtree_weighted[j];
  }
  ws->total_vertices = 0.0;
  for (int32_t j = 0; j < n; ++j) ws->total_vertices += ws->own_vertices[j];
  ws->total_weighted = 0;
  for (int32_t j = 0; j < n; ++j) ws->total_weighted += ws->weighted[j] ? 1 : 0;
}

}  // namespace

WeightedSkeleton BuildWeightedSkeleton(const RawCharacter& ch, std::vector<int32_t>* triangle_joint) {
  WeightedSkeleton ws;
  BuildTopology(ch, &ws);
  DominantJoints(ch, &ws, triangle_joint);
  BuildWeightedTree(ch, *triangle_joint, &ws);
  return ws;
}

bool WeightedSkeleton::IsAncestor(int32_t a, int32_t j) const {
  for (int32_t x = j; x >= 0; x = parent[x]) {
    if (x == a) return true;
  }
  return false;
}

std::vector<int32_t> WeightedSkeleton::MainChain(int32_t root) const {
  std::vector<double> far(n, -1.0);
  for (int32_t j = n - 1; j >= root; --j) {
    if (!IsAncestor(root, j)) continue;
    far[j] = std::max(far[j], (jpos[j] - jpos[root]).norm());
    if (j != root) far[parent[j]] = std::max(far[parent[j]], far[j]);
  }
  std::vector<int32_t> chain{root};
  int32_t cur = root;
  while (!children[cur].empty()) {
    int32_t next = -1;
    for (int pass = 0; pass < 2 && next < 0; ++pass) {
      for (int32_t c : children[cur]) {
        if (pass == 0 && !sub[c]) continue;
        if (next < 0 || far[c] > far[next]) next = c;
      }
    }
    chain.push_back(next);
    cur = next;
  }
  return chain;
}

void MarkSubtree(const WeightedSkeleton& ws, int32_t root, int32_t part, std::vector<int32_t>* joint_part) {
  std::vector<int32_t> stack{root};
  while (!stack.empty()) {
    const int32_t j = stack.back();
    stack.pop_back();
    (*joint_part)[j] = part;
    for (auto it = ws.children[j].rbegin(); it != ws.children[j].rend(); ++it) stack.push_back(*it);
  }
}

void FillJoints(const WeightedSkeleton& ws, std::span<const int32_t> joint_part, int32_t part_index,
                const std::vector<int32_t>& roots, BodyPart* part) {
  std::vector<bool> listed(ws.n, false);
  part->joints.clear();
  for (int32_t j : part->chain) {
    part->joints.push_back(j);
    listed[j] = true;
  }
  std::vector<int32_t> order = part->chain;
  for (int32_t r : roots) {
    if (!listed[r] && std::find(order.begin(), order.end(), r) == order.end()) order.push_back(r);
  }
  for (size_t i = 0; i < order.size(); ++i) {
    std::vector<int32_t> stack{order[i]};
    while (!stack.empty()) {
      const int32_t j = stack.back();
      stack.pop_back();
      if (joint_part[j] != part_index) continue;
      if (!listed[j]) {
        listed[j] = true;
        part->joints.push_back(j);
      }
      for (auto it = ws.children[j].rbegin(); it != ws.children[j].rend(); ++it) {
        if (!listed[*it]) stack.push_back(*it);
      }
    }
  }
}

}  // namespace skinspheres::lib
