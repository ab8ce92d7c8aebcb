// FitSpheres refuses a degenerate rest pose with the reason (and before fitting), instead of
// writing a set of zero radii or one the runtime then refuses. Characters are the tests' tiny
// glTF (tiny_gltf.h) with one thing broken each; the oracle for "the runtime refuses it" is
// CharacterAsset::Create on what the unchecked fit would have produced being impossible to reach:
// the fit must fail with kInvalidData naming the reason.
#include <gtest/gtest.h>

#include "lib/tiny_gltf.h"
#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/runtime/api/character.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

Result<FitResult> FitTiny(const json& j, const std::string& name) {
  const auto path = Write(test::TempDir("degenerate_fit"), name, j.dump());
  auto c = ImportCharacter(path);
  EXPECT_TRUE(c.ok()) << c.error().message;  // the reader accepts these: only the fit can tell
  if (!c.ok()) return c.error();
  auto parts = SplitBodyParts(*c);
  if (!parts.ok()) return parts.error();
  FitSettings settings;
  settings.rays = 12;
  return FitSpheres(*c, *parts, settings);
}

void ExpectDegenerate(const Result<FitResult>& fit, const std::string& needle) {
  ASSERT_FALSE(fit.ok()) << "fitted " << fit->spheres.size() << " spheres";
  EXPECT_EQ(fit.error().code, ErrorCode::kInvalidData);
  EXPECT_NE(fit.error().message.find("degenerate rest pose: " + needle), std::string::npos) << fit.error().message;
  EXPECT_EQ(fit.error().message.find('\n'), std::string::npos);
}

TEST(DegenerateFit, TheTinyCharacterItselfFitsAndTheRuntimeTakesIt) {
  const auto fit = FitTiny(MakeTiny({}), "sound.gltf");
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  EXPECT_GT(fit->report.body_height, 0.0f);
  EXPECT_TRUE(runtime::CharacterAsset::Create(fit->spheres).ok());
}

TEST(DegenerateFit, ZeroInverseBindMatricesAreRefused) {
  TinyOptions o;
  o.edit = [](TinyGltf& t) {
    std::vector<float> zeros(32, 0.0f);
    t.j["skins"][0]["inverseBindMatrices"] = t.Floats(zeros, "MAT4", 16);
  };
  ExpectDegenerate(FitTiny(MakeTiny(o), "zero_ibm.gltf"), "vertex 0 is skinned by bind entry");
}

TEST(DegenerateFit, AJointWithZeroScaleIsRefused) {
  json j = MakeTiny({});
  j["nodes"][1]["scale"] = {0, 0, 0};  // spine: every vertex hangs on it
  ExpectDegenerate(FitTiny(j, "zero_scale.gltf"), "joint 1 'spine' has a singular rest transform (a zero scale)");
  // Zero scale on the root: the spine's world transform is singular through its parent.
  json root = MakeTiny({});
  root["nodes"][0]["scale"] = {1, 0, 1};
  ExpectDegenerate(FitTiny(root, "zero_scale_root.gltf"), "joint 0 'hips' has a singular rest transform");
}

TEST(DegenerateFit, NoExtentOrNoHeightIsRefused) {
  TinyOptions point;
  point.positions = std::vector<float>(12, 0.5f);
  ExpectDegenerate(FitTiny(MakeTiny(point), "point.gltf"), "every vertex of the rest pose is at one point");
  TinyOptions flat;  // the four vertices in the XZ plane
  flat.positions = {0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 1};
  ExpectDegenerate(FitTiny(MakeTiny(flat), "flat.gltf"), "the rest pose has zero height");
}

}  // namespace
}  // namespace skinspheres::lib
