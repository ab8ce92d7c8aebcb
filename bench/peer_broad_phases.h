// Peer broad phases for the benchmarks: Bullet's btDbvtBroadphase and FCL's dynamic AABB tree, set
// up as their own documentation recommends and made to answer exactly what BroadPhaseJob
// answers.
//
// - Bullet (btDbvtBroadphase, default settings and margins): one proxy per sphere; every frame
//   setAabb(sphere's box) for every proxy (what btCollisionWorld::updateAabbs does; the broad
//   phase itself skips boxes still inside their fattened leaf), then calculateOverlappingPairs.
//   Exclusions: an overlap filter callback (Bullet's mechanism for pairs that must never collide),
//   so excluded pairs never enter the pair cache.
// - FCL (DynamicAABBTreeCollisionManager in float, fcl::Spheref): the translation is set only for
//   spheres that moved and the radius only for spheres whose radius changed (then the local box is
//   recomputed); the manager is updated with the moved objects only (update(objects), each one a
//   reinsertion), or with update() (one refit of the whole tree) when more than a quarter moved,
//   and not at all when nothing moved. Exclusions: in the collide callback (FCL has no filter).
//
// Both then run the same float sphere test as ours on their candidate pairs. Two variants:
// Count (how many contacts; no list) and Sorted (the contact list sorted by (i, j), as ours).
// Used by broad_phase_bench (all workloads) and runtime_bench (the fitted Xbot). Only built when
// CMake finds both (SKINSPHERES_HAVE_PEERS=1, see bench/CMakeLists.txt).
#pragma once

#if SKINSPHERES_HAVE_PEERS
#include <btBulletCollisionCommon.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision_object.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"

namespace skinspheres::bench {

namespace rt = skinspheres::runtime;

// The sphere test of broad_phase.h, same float operations. Adds a contact (Sorted) or counts it.
struct PeerOutput {
  std::vector<rt::SpherePair>* list = nullptr;  // null: count only
  size_t count = 0;

  void Test(const skinspheres::Vec4f& a, const skinspheres::Vec4f& b, uint32_t i, uint32_t j, const rt::PairFilter& f) {
    if (i > j) std::swap(i, j);  // squares and sums do not depend on the operand order
    const float dx = b.x() - a.x(), dy = b.y() - a.y(), dz = b.z() - a.z();
    const float d2 = (dx * dx + dy * dy) + dz * dz;
    const float rsum = a.w() + b.w();
    if (!(d2 <= rsum * rsum)) return;
    ++count;
    if (list != nullptr) list->push_back(rt::SpherePair{i, j, rsum - std::sqrt(d2), f.part(i), f.part(j)});
  }
  void Finish() {
    if (list != nullptr) {
      std::sort(list->begin(), list->end(), [](const rt::SpherePair& p, const rt::SpherePair& q) {
        return p.sphere_i != q.sphere_i ? p.sphere_i < q.sphere_i : p.sphere_j < q.sphere_j;
      });
    }
  }
};

struct BulletExclusion : btOverlapFilterCallback {
  const rt::PairFilter* filter = nullptr;
  bool needBroadphaseCollision(btBroadphaseProxy* p0, btBroadphaseProxy* p1) const override {
    return !filter->excluded(uint32_t(reinterpret_cast<uintptr_t>(p0->m_clientObject)),
                             uint32_t(reinterpret_cast<uintptr_t>(p1->m_clientObject)));
  }
};

// One collision configuration and dispatcher for every world (the dispatcher only frees pair
// data here; a configuration per world would cost megabytes of pools each). Single-threaded use.
inline btCollisionDispatcher& SharedBulletDispatcher() {
  static btDefaultCollisionConfiguration config;
  static btCollisionDispatcher dispatcher(&config);
  return dispatcher;
}

class BulletWorld {
 public:
  BulletWorld(std::span<const skinspheres::Vec4f> s, const rt::PairFilter& f) : filter_(&f) {
    exclusion_.filter = &f;
    broadphase_.getOverlappingPairCache()->setOverlapFilterCallback(&exclusion_);
    for (size_t i = 0; i < s.size(); ++i) {
      const btVector3 c(s[i].x(), s[i].y(), s[i].z()), r(s[i].w(), s[i].w(), s[i].w());
      proxies_.push_back(broadphase_.createProxy(c - r, c + r, SPHERE_SHAPE_PROXYTYPE,
                                                 reinterpret_cast<void*>(uintptr_t(i)), 1, -1, &dispatcher_));
    }
  }
  ~BulletWorld() {
    for (btBroadphaseProxy* p : proxies_) broadphase_.destroyProxy(p, &dispatcher_);
  }
  BulletWorld(const BulletWorld&) = delete;
  BulletWorld& operator=(const BulletWorld&) = delete;

  // list == nullptr: count only. Returns the contact count.
  size_t Frame(std::span<const skinspheres::Vec4f> s, std::vector<rt::SpherePair>* list) {
    for (size_t i = 0; i < s.size(); ++i) {
      const btVector3 c(s[i].x(), s[i].y(), s[i].z()), r(s[i].w(), s[i].w(), s[i].w());
      broadphase_.setAabb(proxies_[i], c - r, c + r, &dispatcher_);
    }
    broadphase_.calculateOverlappingPairs(&dispatcher_);
    PeerOutput out{list, 0};
    if (list != nullptr) list->clear();
    btBroadphasePairArray& pairs = broadphase_.getOverlappingPairCache()->getOverlappingPairArray();
    for (int k = 0; k < pairs.size(); ++k) {
      const auto i = uint32_t(reinterpret_cast<uintptr_t>(pairs[k].m_pProxy0->m_clientObject));
      const auto j = uint32_t(reinterpret_cast<uintptr_t>(pairs[k].m_pProxy1->m_clientObject));
      out.Test(s[i], s[j], i, j, *filter_);
    }
    out.Finish();
    last_candidates_ = size_t(pairs.size());
    return out.count;
  }
  size_t last_candidates() const { return last_candidates_; }

 private:
  btCollisionDispatcher& dispatcher_ = SharedBulletDispatcher();
  btDbvtBroadphase broadphase_;
  BulletExclusion exclusion_;
  std::vector<btBroadphaseProxy*> proxies_;
  const rt::PairFilter* filter_;
  size_t last_candidates_ = 0;
};

class FclWorld {
 public:
  FclWorld(std::span<const skinspheres::Vec4f> s, const rt::PairFilter& f) : filter_(&f) {
    current_.assign(s.begin(), s.end());
    for (size_t i = 0; i < s.size(); ++i) {
      shapes_.push_back(std::make_shared<fcl::Spheref>(s[i].w()));
      auto o = std::make_unique<fcl::CollisionObjectf>(shapes_.back());
      o->setTranslation(fcl::Vector3f(s[i].x(), s[i].y(), s[i].z()));
      o->computeAABB();
      o->setUserData(reinterpret_cast<void*>(uintptr_t(i)));
      manager_.registerObject(o.get());
      objects_.push_back(std::move(o));
    }
    manager_.setup();
    moved_.reserve(s.size());
  }

  size_t Frame(std::span<const skinspheres::Vec4f> s, std::vector<rt::SpherePair>* list) {
    moved_.clear();
    for (size_t i = 0; i < s.size(); ++i) {
      const bool radius_changed = s[i].w() != current_[i].w();
      const bool centre_changed = s[i].head<3>() != current_[i].head<3>();
      if (!radius_changed && !centre_changed) continue;
      if (radius_changed) {
        shapes_[i]->radius = s[i].w();
        shapes_[i]->computeLocalAABB();
      }
      if (centre_changed) objects_[i]->setTranslation(fcl::Vector3f(s[i].x(), s[i].y(), s[i].z()));
      objects_[i]->computeAABB();
      current_[i] = s[i];
      moved_.push_back(objects_[i].get());
    }
    if (4 * moved_.size() > s.size()) {
      manager_.update();
    } else if (!moved_.empty()) {
      manager_.update(moved_);
    }
    if (list != nullptr) list->clear();
    Data data{s, filter_, PeerOutput{list, 0}, 0};
    manager_.collide(&data, &FclWorld::Callback);
    data.out.Finish();
    last_candidates_ = data.candidates;
    return data.out.count;
  }
  size_t last_candidates() const { return last_candidates_; }

 private:
  struct Data {
    std::span<const skinspheres::Vec4f> spheres;
    const rt::PairFilter* filter;
    PeerOutput out;
    size_t candidates;
  };
  static bool Callback(fcl::CollisionObjectf* a, fcl::CollisionObjectf* b, void* data) {
    Data& d = *static_cast<Data*>(data);
    const auto i = uint32_t(reinterpret_cast<uintptr_t>(a->getUserData()));
    const auto j = uint32_t(reinterpret_cast<uintptr_t>(b->getUserData()));
    ++d.candidates;
    if (!d.filter->excluded(i, j)) d.out.Test(d.spheres[i], d.spheres[j], i, j, *d.filter);
    return false;
  }

  std::vector<std::shared_ptr<fcl::Spheref>> shapes_;
  std::vector<std::unique_ptr<fcl::CollisionObjectf>> objects_;
  std::vector<fcl::CollisionObjectf*> moved_;
  std::vector<skinspheres::Vec4f> current_;
  fcl::DynamicAABBTreeCollisionManagerf manager_;
  const rt::PairFilter* filter_;
  size_t last_candidates_ = 0;
};

}  // namespace skinspheres::bench
#endif  // SKINSPHERES_HAVE_PEERS
