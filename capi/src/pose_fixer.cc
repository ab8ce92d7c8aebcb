// The C API's pose fixer (skinspheres.h, "Pose fixing") over runtime::PoseFixer.
#include "skinspheres/runtime/fix/pose_fixer.h"

#include "capi_internal.h"

using namespace skinspheres::capi;

struct skinspheres_pose_fixer {
  rt::PoseFixer fixer;
  const skinspheres_asset* asset = nullptr;  // one reference, dropped by skinspheres_pose_fixer_destroy
  std::vector<skinspheres::skinning::Transform> locals;
};

extern "C" {

skinspheres_status skinspheres_pose_fixer_create(const skinspheres_asset* asset, skinspheres_pose_fixer** out_fixer) {
  return Guard([&] {
    if (out_fixer) *out_fixer = nullptr;
    if (asset == nullptr || out_fixer == nullptr)
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null asset or out_fixer");
    auto created = rt::PoseFixer::Create(asset->asset);
    if (!created.ok()) return Fail(created.error());
    *out_fixer = new skinspheres_pose_fixer{
        std::move(*created), skinspheres_asset_retain(const_cast<skinspheres_asset*>(asset)), {}};
    return SKINSPHERES_OK;
  });
}

void skinspheres_pose_fixer_destroy(skinspheres_pose_fixer* fixer) {
  if (fixer == nullptr) return;
  skinspheres_asset* asset = const_cast<skinspheres_asset*>(fixer->asset);
  delete fixer;
  skinspheres_asset_release(asset);
}

skinspheres_status skinspheres_pose_fixer_fix(skinspheres_pose_fixer* fixer, float* locals, size_t joint_count,
                                              float max_depth, skinspheres_pose_fix_result* out_result) {
  return Guard([&] {
    if (fixer == nullptr || locals == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null fixer or locals");
    if (joint_count != fixer->asset->asset->sphere_set().joint_count()) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "joint_count is not the asset's joint count");
    }
    fixer->locals.resize(joint_count);
    for (size_t j = 0; j < joint_count; ++j) {
      const float* f = locals + 10 * j;
      auto& t = fixer->locals[j];
      t.translation = Eigen::Vector3f(f[0], f[1], f[2]);
      t.rotation = skinspheres::Quatf(f[6], f[3], f[4], f[5]);  // (w, x, y, z)
      t.scale = Eigen::Vector3f(f[7], f[8], f[9]);
    }
    rt::PoseSolveSettings settings;
    settings.max_depth = max_depth;
    auto result = fixer->fixer.Fix(fixer->locals, settings);
    if (!result.ok()) return Fail(result.error());
    for (size_t j = 0; j < joint_count; ++j) {
      const auto& q = fixer->locals[j].rotation;
      float* f = locals + 10 * j;
      f[3] = q.x(), f[4] = q.y(), f[5] = q.z(), f[6] = q.w();
    }
    if (out_result) *out_result = {result->holds ? 1 : 0, result->steps, result->deepest_before, result->deepest_after};
    return SKINSPHERES_OK;
  });
}

}  // extern "C"
