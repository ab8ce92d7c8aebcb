// SkinningMatricesJob: M_b = G_joint(b) · IBM_b per bind entry, the bind pose giving identity
// skinning matrices, and refusals.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "skinning/synthetic_mesh.h"
#include "skinspheres/skinning/skinning_matrices_job.h"

namespace skinspheres::skinning {
namespace {

TEST(SkinningMatricesJob, ProductPerBindAndIdentityInBindPose) {
  std::mt19937 rng(2);
  std::vector<skinspheres::Mat4f> model;
  for (int j = 0; j < 6; ++j) model.push_back(test::RandomAffine(rng));
  std::vector<BindEntry> binds;
  for (int b = 0; b < 9; ++b) binds.push_back(BindEntry{b % 6, test::RandomAffine(rng)});
  std::vector<skinspheres::Mat4f> out(binds.size());
  SkinningMatricesJob job{binds, model, out};
  ASSERT_TRUE(job.Run());
  for (size_t b = 0; b < binds.size(); ++b) EXPECT_TRUE(out[b].isApprox(model[binds[b].joint] * binds[b].inverse_bind));
  // In the bind pose IBM_b = G_joint^-1, so M_b = I.
  for (BindEntry& b : binds) b.inverse_bind = model[b.joint].inverse();
  ASSERT_TRUE(job.Run());
  for (const skinspheres::Mat4f& m : out) EXPECT_LT((m - skinspheres::Mat4f::Identity()).cwiseAbs().maxCoeff(), 1e-5f);
}

TEST(SkinningMatricesJob, RefusesBadJobs) {
  std::vector<skinspheres::Mat4f> model(3, skinspheres::Mat4f::Identity()), out(2);
  std::vector<BindEntry> binds = {BindEntry{0, skinspheres::Mat4f::Identity()},
                                  BindEntry{2, skinspheres::Mat4f::Identity()}};
  EXPECT_TRUE((SkinningMatricesJob{binds, model, out}.Validate()));
  EXPECT_FALSE((SkinningMatricesJob{binds, model, std::span<skinspheres::Mat4f>(out).first(1)}.Run()));
  EXPECT_FALSE((SkinningMatricesJob{binds, std::span<const skinspheres::Mat4f>(model).first(2), out}.Run()));
  binds[0].joint = -1;
  EXPECT_FALSE((SkinningMatricesJob{binds, model, out}.Run()));
}

}  // namespace
}  // namespace skinspheres::skinning
