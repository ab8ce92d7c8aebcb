// Fuzz target: the fit pipeline (body parts, disk traversal, spheres, ownership, tightening) on
// small characters decoded from the bytes: up to 6 joints (translations, rotations, scales that
// may be zero), up to 48 vertices on a coarse grid (so coincident vertices, flat and collinear
// triangles come up), up to 64 triangles, 1 or 2 influences per vertex, inverse bind matrices
// that may be the rest inverse, the identity or zero, and small fit settings.
// Properties: a refusal is one line naming the character, never a failed self-check; a fitted set
// proves every triangle inside its owner at rest, passes Validate, reads back from its own JSON,
// and is accepted by the runtime (CharacterAsset), whose exact refit at the rest pose holds every
// triangle too.
#include <tbb/global_control.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "fuzz_check.h"
#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/format/sphere_set_io.h"

namespace {

using namespace skinspheres;

// Bytes in order; zeros once they run out.
struct Bytes {
  const uint8_t* data;
  size_t size;
  size_t at = 0;
  uint8_t Next() { return at < size ? data[at++] : 0; }
  float Signed(float unit) { return (static_cast<int>(Next()) - 128) * unit; }
};

lib::RawCharacter Decode(Bytes& in, lib::FitSettings* settings) {
  lib::RawCharacter c;
  c.source_file = "fuzz";
  const int joints = 1 + in.Next() % 6;
  for (int j = 0; j < joints; ++j) {
    c.skeleton.joint_names.push_back("joint" + std::to_string(j));
    c.skeleton.parents.push_back(j == 0 ? -1 : in.Next() % j);
    skinning::Transform t;
    t.translation = Eigen::Vector3f(in.Signed(0.02f), in.Signed(0.02f), in.Signed(0.02f));
    if (in.Next() % 4 == 0) t.rotation = Quatf(Eigen::AngleAxisf(in.Signed(0.05f), Eigen::Vector3f::UnitX()));
    const uint8_t scale = in.Next();
    if (scale % 8 == 0) t.scale = Eigen::Vector3f::Constant((scale / 8) % 4 * 0.5f);  // 0, 0.5, 1 or 1.5
    c.skeleton.rest_local.push_back(t);
  }
  std::vector<Mat4f> world(joints);
  c.skeleton.RestWorld(world);
  for (int j = 0; j < joints; ++j) {
    const uint8_t kind = in.Next() % 8;
    Mat4f ibm = Mat4f::Identity();
    if (kind == 0)
      ibm = Mat4f::Zero();
    else if (kind >= 2 && std::abs(world[j].topLeftCorner<3, 3>().determinant()) > 1e-6f)
      ibm = world[j].inverse();
    c.skin.binds.push_back({j, ibm});
  }
  const int vertices = 3 + in.Next() % 46;
  c.skin.influence_offsets.push_back(0);
  for (int v = 0; v < vertices; ++v) {
    c.skin.positions_bind.emplace_back(in.Signed(0.01f), in.Signed(0.01f) + 1.0f, in.Signed(0.01f));
    const uint8_t a = in.Next(), b = in.Next();
    c.skin.influence_binds.push_back(static_cast<uint16_t>(a % joints));
    if (b % 4 == 0 && b / 4 % joints != a % joints) {
      c.skin.influence_binds.push_back(static_cast<uint16_t>(b / 4 % joints));
      c.skin.influence_weights.push_back(0.75f);
      c.skin.influence_weights.push_back(0.25f);
    } else {
      c.skin.influence_weights.push_back(1.0f);
    }
    c.skin.influence_offsets.push_back(static_cast<uint32_t>(c.skin.influence_binds.size()));
  }
  // Rest positions as the importer makes them: sum of w * G * IBM * p_bind.
  for (int v = 0; v < vertices; ++v) {
    Vec4f p = Vec4f::Zero();
    for (uint32_t k = c.skin.influence_offsets[v]; k < c.skin.influence_offsets[v + 1]; ++k) {
      const auto& bind = c.skin.binds[c.skin.influence_binds[k]];
      p += c.skin.influence_weights[k] *
           (world[bind.joint] * bind.inverse_bind * c.skin.positions_bind[v].homogeneous());
    }
    c.positions_rest.push_back(p.head<3>());
  }
  const int triangles = 1 + in.Next() % 64;
  for (int t = 0; t < triangles; ++t)
    c.triangles.emplace_back(in.Next() % vertices, in.Next() % vertices, in.Next() % vertices);
  c.meshes.push_back({"mesh", 0, static_cast<uint32_t>(vertices), 0, static_cast<uint32_t>(triangles), true, -1});

  settings->rays = 3 + in.Next() % 14;
  settings->per_level = 1 << (in.Next() % 3);
  settings->method = static_cast<lib::SphereMethod>(in.Next() % 3);
  settings->overlap = (in.Next() % 10) * 0.1f;
  settings->step = 0.05f + (in.Next() % 20) * 0.05f;
  settings->refine_iterations = in.Next() % 3;
  settings->tighten = in.Next() % 2 == 0;
  settings->max_spheres = 1 + in.Next() % 24;
  settings->contact_hops = int(in.Next() % 3);
  return c;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // One thread: the fit does not depend on the thread count, and the fuzzer shares the machine.
  static tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Bytes in{data, size};
  lib::FitSettings settings;
  const lib::RawCharacter c = Decode(in, &settings);
  auto parts = lib::SplitBodyParts(c);
  if (!parts.ok()) {
    fuzz::CheckError(parts.error(), "fuzz");
    return 0;
  }
  auto fit = lib::FitSpheres(c, *parts, settings);
  if (!fit.ok()) {
    fuzz::CheckError(fit.error(), "fuzz");
    return 0;
  }
  const runtime::SphereSet& set = fit->spheres;
  SKINSPHERES_FUZZ_CHECK(lib::CountUncoveredTriangles(c, set) == 0, "a fitted triangle outside its sphere");
  SKINSPHERES_FUZZ_CHECK(!set.Validate().has_value(), set.Validate()->message);
  auto read = runtime::ReadSphereSetJson(runtime::WriteSphereSetJson(set), "fuzz");
  SKINSPHERES_FUZZ_CHECK(read.ok(), read.ok() ? "" : read.error().message);
  // What `fit` writes, `play` must accept.
  auto asset = runtime::CharacterAsset::Create(std::move(read).value());
  SKINSPHERES_FUZZ_CHECK(asset.ok(), asset.ok() ? "" : asset.error().message);
  auto instance = runtime::CharacterInstance::Create(*asset);
  SKINSPHERES_FUZZ_CHECK(instance.ok(), "instance");
  std::vector<Mat4f> rest(c.skeleton.size());
  c.skeleton.RestWorld(rest);
  const auto status = instance->UpdateExact(c.positions_rest, rest);
  SKINSPHERES_FUZZ_CHECK(status.ok(), status.message);
  const auto spheres = instance->spheres();
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      for (int v = 0; v < 3; ++v) {
        const Eigen::Vector3d p = c.positions_rest[c.triangles[set.triangles[k]][v]].cast<double>();
        const double d = (p - spheres[s].head<3>().cast<double>()).norm();
        SKINSPHERES_FUZZ_CHECK(d <= spheres[s].w() * (1.0 + 1e-5) + 1e-30,
                               "exact refit at rest leaves a vertex outside");
      }
    }
  }
  instance->FindSpherePairs();
  return 0;
}
