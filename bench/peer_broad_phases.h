// Peer broad phases for the benchmarks: Bullet's btDbvtBroadphase and FCL's dynamic AABB tree,
// set up to answer exactly what SelfCollisionJob answers. Every sphere's box (and, for FCL, its
// radius: refit changes radii) is updated every frame, so their update cost is counted; candidate
// pairs go through the same exclusions (PairFilter) and the same float sphere test; contacts are
// sorted by (i, j). Used by broad_phase_bench (synthetic sets) and runtime_bench (the fitted Xbot).
// Only built when CMake finds both (SKINSPHERES_HAVE_PEERS=1, see bench/CMakeLists.txt).
#pragma once

#if SKINSPHERES_HAVE_PEERS
#include <btBulletCollisionCommon.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision_object.h>
#include <memory>
#include <vector>

#include "skinspheres/runtime/broad_phase.h"
#include "skinspheres/runtime/pair_filter.h"

namespace skinspheres::bench {

namespace rt = skinspheres::runtime;

inline void PeerSphereTest(const skinspheres::Vec4f& a, const skinspheres::Vec4f& b, uint32_t i, uint32_t j,
                           const rt::PairFilter& f, std::vector<rt::Contact>* out) {
  if (i > j) std::swap(i, j);  // squares and sums do not depend on the operand order
  const float dx = b.x() - a.x(), dy = b.y() - a.y(), dz = b.z() - a.z();
  const float d2 = (dx * dx + dy * dy) + dz * dz;
  const float rsum = a.w() + b.w();
  if (d2 <= rsum * rsum) out->push_back(rt::Contact{i, j, rsum - std::sqrt(d2), f.part(i), f.part(j)});
}

inline void SortContacts(std::vector<rt::Contact>* out) {
  std::sort(out->begin(), out->end(),
            [](const rt::Contact& p, const rt::Contact& q) { return p.i != q.i ? p.i < q.i : p.j < q.j; });
}

struct BulletExclusion : btOverlapFilterCallback {
  const rt::PairFilter* filter = nullptr;
  bool needBroadphaseCollision(btBroadphaseProxy* p0, btBroadphaseProxy* p1) const override {
    return !filter->excluded(uint32_t(reinterpret_cast<uintptr_t>(p0->m_clientObject)),
                             uint32_t(reinterpret_cast<uintptr_t>(p1->m_clientObject)));
  }
};

struct BulletWorld {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  BulletExclusion exclusion;
  std::vector<btBroadphaseProxy*> proxies;
  const rt::PairFilter* filter;

  BulletWorld(const std::vector<skinspheres::Vec4f>& s, const rt::PairFilter& f) : filter(&f) {
    exclusion.filter = &f;
    broadphase.getOverlappingPairCache()->setOverlapFilterCallback(&exclusion);
    for (size_t i = 0; i < s.size(); ++i) {
      const btVector3 c(s[i].x(), s[i].y(), s[i].z()), r(s[i].w(), s[i].w(), s[i].w());
      proxies.push_back(broadphase.createProxy(c - r, c + r, SPHERE_SHAPE_PROXYTYPE,
                                               reinterpret_cast<void*>(uintptr_t(i)), 1, -1, &dispatcher));
    }
  }
  void Frame(const std::vector<skinspheres::Vec4f>& s, std::vector<rt::Contact>* out) {
    for (size_t i = 0; i < s.size(); ++i) {
      const btVector3 c(s[i].x(), s[i].y(), s[i].z()), r(s[i].w(), s[i].w(), s[i].w());
      broadphase.setAabb(proxies[i], c - r, c + r, &dispatcher);
    }
    broadphase.calculateOverlappingPairs(&dispatcher);
    out->clear();
    btBroadphasePairArray& pairs = broadphase.getOverlappingPairCache()->getOverlappingPairArray();
    for (int k = 0; k < pairs.size(); ++k) {
      const auto i = uint32_t(reinterpret_cast<uintptr_t>(pairs[k].m_pProxy0->m_clientObject));
      const auto j = uint32_t(reinterpret_cast<uintptr_t>(pairs[k].m_pProxy1->m_clientObject));
      PeerSphereTest(s[i], s[j], i, j, *filter, out);
    }
    SortContacts(out);
  }
};

struct FclWorld {
  std::vector<std::shared_ptr<fcl::Sphered>> shapes;
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects;
  fcl::DynamicAABBTreeCollisionManagerd manager;
  const rt::PairFilter* filter;
  struct Data {
    const std::vector<skinspheres::Vec4f>* spheres;
    const rt::PairFilter* filter;
    std::vector<rt::Contact>* out;
  };
  FclWorld(const std::vector<skinspheres::Vec4f>& s, const rt::PairFilter& f) : filter(&f) {
    for (size_t i = 0; i < s.size(); ++i) {
      shapes.push_back(std::make_shared<fcl::Sphered>(double(s[i].w())));
      auto o = std::make_unique<fcl::CollisionObjectd>(shapes.back());
      o->setTranslation(s[i].head<3>().cast<double>());
      o->computeAABB();
      o->setUserData(reinterpret_cast<void*>(uintptr_t(i)));
      manager.registerObject(o.get());
      objects.push_back(std::move(o));
    }
    manager.setup();
  }
  static bool Callback(fcl::CollisionObjectd* a, fcl::CollisionObjectd* b, void* data) {
    const Data& d = *static_cast<const Data*>(data);
    const auto i = uint32_t(reinterpret_cast<uintptr_t>(a->getUserData()));
    const auto j = uint32_t(reinterpret_cast<uintptr_t>(b->getUserData()));
    if (!d.filter->excluded(i, j)) PeerSphereTest((*d.spheres)[i], (*d.spheres)[j], i, j, *d.filter, d.out);
    return false;
  }
  // Radii change every frame (refit): the sphere geometry's radius is updated too.
  void Frame(const std::vector<skinspheres::Vec4f>& s, std::vector<rt::Contact>* out) {
    for (size_t i = 0; i < s.size(); ++i) {
      shapes[i]->radius = double(s[i].w());
      shapes[i]->computeLocalAABB();
      objects[i]->setTranslation(s[i].head<3>().cast<double>());
      objects[i]->computeAABB();
    }
    manager.update();
    out->clear();
    Data data{&s, filter, out};
    manager.collide(&data, &FclWorld::Callback);
    SortContacts(out);
  }
};

}  // namespace skinspheres::bench
#endif  // SKINSPHERES_HAVE_PEERS
