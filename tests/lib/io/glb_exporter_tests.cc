// Tests for ExportGlb: the written file is read back by Assimp (an independent reader) and by
// ImportCharacter (the project's importer), and compared with what was exported.
#include <assimp/cimport.h>
#include <assimp/scene.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/io/clip_import.h"
#include "skinspheres/lib/io/glb_exporter.h"
#include "skinspheres/lib/io/importer.h"
#include "support/clip_eval_for_tests.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

using Eigen::Vector3f;

struct AiScene {
  const aiScene* scene = nullptr;
  explicit AiScene(const std::filesystem::path& p) : scene(aiImportFile(p.string().c_str(), 0)) {}
  ~AiScene() { aiReleaseImport(scene); }
  AiScene(const AiScene&) = delete;
  AiScene& operator=(const AiScene&) = delete;
};

const aiAnimation* FindAnim(const aiScene* s, const std::string& name) {
  for (unsigned i = 0; i < s->mNumAnimations; ++i) {
    if (name == s->mAnimations[i]->mName.C_Str()) return s->mAnimations[i];
  }
  return nullptr;
}

const aiNodeAnim* FindChannel(const aiAnimation* a, const std::string& node) {
  for (unsigned i = 0; i < a->mNumChannels; ++i) {
    if (node == a->mChannels[i]->mNodeName.C_Str()) return a->mChannels[i];
  }
  return nullptr;
}

std::filesystem::path ExportBuiltin(const std::string& folder, const GlbExtras& extras = {}) {
  const auto path = test::TempDir(folder) / "builtin.glb";
  const auto r = ExportGlb(test::BuiltinCharacter(), path, extras);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return path;
}

TEST(GlbExporter, AssimpReadsBackMeshesSkinAndClips) {
  const RawCharacter& c = test::BuiltinCharacter();
  const auto path = ExportBuiltin("glb_exporter_assimp");
  AiScene in(path);
  ASSERT_NE(in.scene, nullptr) << aiGetErrorString();
  const aiScene* s = in.scene;
  ASSERT_EQ(s->mNumMeshes, c.meshes.size());
  size_t triangles = 0;
  std::set<std::string> bone_names;
  for (unsigned m = 0; m < s->mNumMeshes; ++m) {
    const aiMesh* mesh = s->mMeshes[m];
    const MeshRange& range = c.meshes[m];
    EXPECT_EQ(range.name, mesh->mName.C_Str());
    ASSERT_EQ(mesh->mNumVertices, range.vertex_count) << range.name;
    ASSERT_EQ(mesh->mNumFaces, range.triangle_count) << range.name;
    triangles += mesh->mNumFaces;
    for (unsigned f = 0; f < mesh->mNumFaces; f += 37) {
      ASSERT_EQ(mesh->mFaces[f].mNumIndices, 3u);
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(mesh->mFaces[f].mIndices[k] + range.first_vertex,
                  static_cast<unsigned>(c.triangles[range.first_triangle + f][k]));
      }
    }
    for (unsigned v = 0; v < mesh->mNumVertices; v += 17) {
      const aiVector3D& p = mesh->mVertices[v];
      EXPECT_LT((Vector3f(p.x, p.y, p.z) - c.positions_rest[range.first_vertex + v]).norm(), 1e-6f);
    }
    // Weights per (vertex, joint) equal the character's.
    std::vector<std::map<std::string, float>> weights(mesh->mNumVertices);
    for (unsigned b = 0; b < mesh->mNumBones; ++b) {
      const aiBone* bone = mesh->mBones[b];
      bone_names.insert(bone->mName.C_Str());
      const int32_t j = c.skeleton.Find(bone->mName.C_Str());
      ASSERT_GE(j, 0) << bone->mName.C_Str();
      // Offset matrix = inverse bind matrix.
      const auto& ibm = c.skin.binds[j].inverse_bind;
      EXPECT_NEAR(bone->mOffsetMatrix.a4, ibm(0, 3), 1e-6f);
      EXPECT_NEAR(bone->mOffsetMatrix.b4, ibm(1, 3), 1e-6f);
      EXPECT_NEAR(bone->mOffsetMatrix.c4, ibm(2, 3), 1e-6f);
      for (unsigned w = 0; w < bone->mNumWeights; ++w) {
        if (bone->mWeights[w].mWeight > 0)
          weights[bone->mWeights[w].mVertexId][bone->mName.C_Str()] += bone->mWeights[w].mWeight;
      }
    }
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const uint32_t gv = range.first_vertex + v;
      ASSERT_EQ(weights[v].size(), c.skin.influence_offsets[gv + 1] - c.skin.influence_offsets[gv])
          << range.name << " " << v;
      for (uint32_t k = c.skin.influence_offsets[gv]; k < c.skin.influence_offsets[gv + 1]; ++k) {
        const std::string& joint = c.skeleton.joint_names[c.skin.binds[c.skin.influence_binds[k]].joint];
        EXPECT_NEAR(weights[v][joint], c.skin.influence_weights[k], 1e-6f);
      }
    }
  }
  EXPECT_EQ(triangles, c.triangle_count());
  EXPECT_GE(bone_names.size(), 20u);
  for (const auto& name : c.skeleton.joint_names) {
    EXPECT_NE(s->mRootNode->FindNode(name.c_str()), nullptr) << name;
  }
  // Clips: one animation per clip, with the clip's name and duration.
  ASSERT_EQ(s->mNumAnimations, c.clips.size());
  for (const auto& clip : c.clips) {
    const aiAnimation* a = FindAnim(s, clip.name);
    ASSERT_NE(a, nullptr) << clip.name;
    const double tps = a->mTicksPerSecond > 0 ? a->mTicksPerSecond : 1.0;
    EXPECT_NEAR(a->mDuration / tps, clip.duration_s, 1e-4) << clip.name;
  }
  // A rotation key of the touch clip: LeftArm at the chest key.
  const auto& touch = c.clips[1];
  const aiNodeAnim* ch = FindChannel(FindAnim(s, "touch"), "LeftArm");
  ASSERT_NE(ch, nullptr);
  for (const auto& tr : touch.tracks) {
    if (c.skeleton.joint_names[tr.joint] != "LeftArm") continue;
    ASSERT_EQ(ch->mNumRotationKeys, tr.rotation.times_s.size());
    const skinspheres::Quatf q = tr.rotation.values[1];
    const aiQuaternion& k = ch->mRotationKeys[1].mValue;
    EXPECT_NEAR(std::abs(q.w() * k.w + q.x() * k.x + q.y() * k.y + q.z() * k.z), 1.0f, 1e-6f);
  }
}

TEST(GlbExporter, RoundTripThroughImportCharacter) {
  const RawCharacter& c = test::BuiltinCharacter();
  const auto path = ExportBuiltin("glb_exporter_roundtrip");
  const auto imported = ImportCharacter(path);
  ASSERT_TRUE(imported.ok()) << imported.error().message;
  const RawCharacter& r = *imported;
  EXPECT_EQ(r.skeleton.joint_names, c.skeleton.joint_names);
  ASSERT_EQ(r.vertex_count(), c.vertex_count());
  EXPECT_EQ(r.triangles, c.triangles);
  Eigen::AlignedBox3f box;
  for (const auto& p : c.positions_rest) box.extend(p);
  const float tol = 1e-5f * box.sizes().maxCoeff();
  for (size_t v = 0; v < c.vertex_count(); ++v) {
    ASSERT_LT((r.positions_rest[v] - c.positions_rest[v]).norm(), tol) << v;
  }
  // Clips: same names; sampled local transforms of every joint (matched by name) agree, and so
  // does the skinned shape. STEP keys are baked with a 1e-4 s hold and CUBICSPLINE with 8 chords
  // per interval, hence the small tolerance on translations.
  ASSERT_EQ(r.clips.size(), c.clips.size());
  for (const auto& clip : c.clips) {
    const skinning::AnimationClip* rc = nullptr;
    for (const auto& k : r.clips) {
      if (k.name == clip.name) rc = &k;
    }
    ASSERT_NE(rc, nullptr) << clip.name;
    EXPECT_NEAR(rc->duration_s, clip.duration_s, 1e-5f);
    for (int i = 0; i <= 40; ++i) {
      const float t = clip.duration_s * static_cast<float>(i) / 40.0f + (i % 2 ? 0.0013f : 0.0f);
      const auto a = test::SampleLocal(c, clip, t);
      const auto b = test::SampleLocal(r, *rc, t);
      for (size_t j = 0; j < a.size(); ++j) {
        const int32_t jr = r.skeleton.Find(c.skeleton.joint_names[j]);
        ASSERT_GE(jr, 0);
        EXPECT_LT((a[j].translation - b[jr].translation).norm(), 1e-4f)
            << clip.name << " " << c.skeleton.joint_names[j] << " t=" << t;
        EXPECT_GT(std::abs(a[j].rotation.dot(b[jr].rotation)), 1.0f - 1e-5f)
            << clip.name << " " << c.skeleton.joint_names[j] << " t=" << t;
        EXPECT_LT((a[j].scale - b[jr].scale).norm(), 1e-5f);
      }
      const auto pa = test::PoseAt(c, clip, t), pb = test::PoseAt(r, *rc, t);
      float worst = 0;
      for (size_t v = 0; v < pa.size(); ++v) worst = std::max(worst, (pa[v] - pb[v]).norm());
      EXPECT_LT(worst, 2e-4f) << clip.name << " t=" << t;
    }
  }
}

TEST(GlbExporter, AnimatedSpheresBecomeNodesWithTheirOwnClip) {
  GlbExtras extras;
  extras.frame_times_s = {0.0f, 0.5f, 1.0f};
  for (int i = 0; i < 3; ++i) {
    AnimatedSphere s;
    for (int f = 0; f < 3; ++f) s.per_frame_xyzr.emplace_back(0.1f * i, 1.0f + 0.1f * f, -0.2f * f, 0.05f + 0.01f * i);
    extras.spheres.push_back(s);
  }
  extras.sphere_segments = 12;
  extras.sphere_rings = 6;
  const auto path = ExportBuiltin("glb_exporter_spheres", extras);
  AiScene in(path);
  ASSERT_NE(in.scene, nullptr) << aiGetErrorString();
  const aiScene* s = in.scene;
  ASSERT_NE(FindAnim(s, "walk"), nullptr);
  ASSERT_NE(FindAnim(s, "touch"), nullptr);
  const aiAnimation* a = FindAnim(s, "spheres");
  ASSERT_NE(a, nullptr);
  for (int i = 0; i < 3; ++i) {
    const std::string name = "sphere_" + std::to_string(i);
    const aiNode* node = s->mRootNode->FindNode(name.c_str());
    ASSERT_NE(node, nullptr);
    ASSERT_EQ(node->mNumMeshes, 1u);
    const aiMesh* mesh = s->mMeshes[node->mMeshes[0]];
    EXPECT_EQ(mesh->mNumVertices, 12u * 6u + 2u);
    EXPECT_EQ(mesh->mNumFaces, 2u * 12u * 6u - 2u * 12u + 2u * 12u);
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      EXPECT_NEAR(Vector3f(mesh->mVertices[v].x, mesh->mVertices[v].y, mesh->mVertices[v].z).norm(), 1.0f, 1e-5f);
    }
    const aiNodeAnim* ch = FindChannel(a, name);
    ASSERT_NE(ch, nullptr);
    ASSERT_EQ(ch->mNumPositionKeys, 3u);
    ASSERT_EQ(ch->mNumScalingKeys, 3u);
    const double tps = a->mTicksPerSecond > 0 ? a->mTicksPerSecond : 1.0;
    for (int f = 0; f < 3; ++f) {
      const skinspheres::Vec4f& e = extras.spheres[i].per_frame_xyzr[f];
      EXPECT_NEAR(ch->mPositionKeys[f].mTime / tps, extras.frame_times_s[f], 1e-5);
      EXPECT_NEAR(ch->mPositionKeys[f].mValue.x, e.x(), 1e-6f);
      EXPECT_NEAR(ch->mPositionKeys[f].mValue.y, e.y(), 1e-6f);
      EXPECT_NEAR(ch->mPositionKeys[f].mValue.z, e.z(), 1e-6f);
      EXPECT_NEAR(ch->mScalingKeys[f].mValue.x, e.w(), 1e-6f);
      EXPECT_NEAR(ch->mScalingKeys[f].mValue.z, e.w(), 1e-6f);
    }
  }
}

// Normals: every exported mesh carries unit normals. The head is an ellipsoid (semi-axes 0.085 x
// 0.11 x 0.10, builtin_character.h), whose outward normal at a surface point p is known: the
// gradient (x/a^2, y/b^2, z/c^2) about its centre. Away from the neck seam every head normal
// must lie within a few degrees of it (smooth area-weighted normals of a fine tessellation).
TEST(GlbExporter, MeshesCarryUnitNormalsThatFollowTheSurface) {
  const auto path = ExportBuiltin("glb_exporter_normals");
  AiScene in(path);
  ASSERT_NE(in.scene, nullptr) << aiGetErrorString();
  const aiMesh* head = nullptr;
  for (unsigned m = 0; m < in.scene->mNumMeshes; ++m) {
    const aiMesh* mesh = in.scene->mMeshes[m];
    ASSERT_TRUE(mesh->HasNormals()) << mesh->mName.C_Str();
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& n = mesh->mNormals[v];
      ASSERT_NEAR(Vector3f(n.x, n.y, n.z).norm(), 1.0f, 1e-4f) << mesh->mName.C_Str() << " " << v;
    }
    if (std::string(mesh->mName.C_Str()) == "HeadMesh") head = mesh;
  }
  ASSERT_NE(head, nullptr);
  Vector3f lo = Vector3f::Constant(1e9f), hi = Vector3f::Constant(-1e9f);
  for (unsigned v = 0; v < head->mNumVertices; ++v) {
    const Vector3f p(head->mVertices[v].x, head->mVertices[v].y, head->mVertices[v].z);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vector3f centre = 0.5f * (lo + hi), semi(0.085f, 0.11f, 0.10f);
  EXPECT_LT(((hi - lo) * 0.5f - semi).cwiseAbs().maxCoeff(), 0.01f) << "the head is not the documented ellipsoid";
  size_t checked = 0;
  float worst = 0.0f;
  for (unsigned v = 0; v < head->mNumVertices; ++v) {
    const Vector3f p = Vector3f(head->mVertices[v].x, head->mVertices[v].y, head->mVertices[v].z) - centre;
    if (p.y() < -0.5f * semi.y()) continue;  // the neck joins below
    const Vector3f gradient = p.cwiseQuotient(semi.cwiseProduct(semi)).normalized();
    const aiVector3D& n = head->mNormals[v];
    worst = std::max(worst, std::acos(std::clamp(gradient.dot(Vector3f(n.x, n.y, n.z)), -1.0f, 1.0f)));
    ++checked;
  }
  EXPECT_GT(checked, head->mNumVertices / 2);
  EXPECT_LT(worst * 180.0f / 3.14159265f, 8.0f) << "largest angle to the ellipsoid's normal";
}

// extras.clip_name naming a character clip: the spheres move in that clip's animation, and no
// extra animation is written.
TEST(GlbExporter, AnimatedSpheresJoinTheNamedClip) {
  GlbExtras extras;
  extras.clip_name = "touch";
  extras.frame_times_s = {0.0f, 1.0f, 2.0f, 3.0f};
  for (int i = 0; i < 2; ++i) {
    AnimatedSphere s;
    for (int f = 0; f < 4; ++f) s.per_frame_xyzr.emplace_back(0.1f * i, 1.0f + 0.1f * f, 0.05f * f, 0.05f + 0.01f * f);
    extras.spheres.push_back(s);
  }
  const auto path = ExportBuiltin("glb_exporter_spheres_in_clip", extras);
  AiScene in(path);
  ASSERT_NE(in.scene, nullptr) << aiGetErrorString();
  const aiScene* s = in.scene;
  EXPECT_EQ(s->mNumAnimations, test::BuiltinCharacter().clips.size());
  EXPECT_EQ(FindAnim(s, "spheres"), nullptr);
  const aiAnimation* touch = FindAnim(s, "touch");
  ASSERT_NE(touch, nullptr);
  EXPECT_NE(FindChannel(touch, "LeftArm"), nullptr);  // the character's own channels stay
  const double tps = touch->mTicksPerSecond > 0 ? touch->mTicksPerSecond : 1.0;
  EXPECT_NEAR(touch->mDuration / tps, kTouchDuration_s, 1e-4);
  for (int i = 0; i < 2; ++i) {
    const aiNodeAnim* ch = FindChannel(touch, "sphere_" + std::to_string(i));
    ASSERT_NE(ch, nullptr) << i;
    ASSERT_EQ(ch->mNumPositionKeys, 4u);
    for (int f = 0; f < 4; ++f) {
      EXPECT_NEAR(ch->mPositionKeys[f].mTime / tps, extras.frame_times_s[f], 1e-5);
      EXPECT_NEAR(ch->mPositionKeys[f].mValue.y, extras.spheres[i].per_frame_xyzr[f].y(), 1e-6f);
      EXPECT_NEAR(ch->mScalingKeys[f].mValue.x, extras.spheres[i].per_frame_xyzr[f].w(), 1e-6f);
    }
    EXPECT_EQ(FindChannel(FindAnim(s, "walk"), "sphere_" + std::to_string(i)), nullptr);
  }
}

// The in-memory export is the file's bytes, and names the node holding each mesh range.
TEST(GlbExporter, MemoryExportIsTheFileAndNamesTheMeshNodes) {
  const auto path = ExportBuiltin("glb_exporter_memory");
  std::ifstream f(path, std::ios::binary);
  const std::vector<uint8_t> file((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const auto blob = ExportGlbToMemory(test::BuiltinCharacter(), "builtin");
  ASSERT_TRUE(blob.ok()) << blob.error().message;
  // The same bytes: Assimp 5.2.5 leaves the gaps between bufferViews uninitialised (heap contents
  // in a file), and the exporter zeroes them, so two exports of one scene are identical.
  ASSERT_EQ(blob->bytes.size(), file.size());
  EXPECT_TRUE(std::equal(file.begin(), file.end(), blob->bytes.begin()));
  ASSERT_GT(file.size(), 28u);
  uint32_t json_length = 0;
  std::memcpy(&json_length, file.data() + 12, 4);
  ASSERT_TRUE(std::equal(file.begin(), file.begin() + 20 + json_length, blob->bytes.begin()));
  const auto gltf = nlohmann::json::parse(file.begin() + 20, file.begin() + 20 + json_length);
  const size_t bin = 20 + json_length + 8;
  std::vector<char> viewed(file.size() - bin, 0);
  for (const auto& view : gltf["bufferViews"]) {
    const size_t begin = bin + view.value("byteOffset", size_t{0}), end = begin + view["byteLength"].get<size_t>();
    ASSERT_LE(end, file.size());
    std::fill(viewed.begin() + static_cast<std::ptrdiff_t>(begin - bin),
              viewed.begin() + static_cast<std::ptrdiff_t>(end - bin), 1);
  }
  size_t unviewed = 0, nonzero = 0;
  for (size_t k = 0; k < viewed.size(); ++k) {
    if (viewed[k]) continue;
    ++unviewed;
    nonzero += file[bin + k] != 0;
  }
  EXPECT_GT(unviewed, 0u) << "no gap left to check: Assimp no longer leaves any";
  EXPECT_EQ(nonzero, 0u) << "of " << unviewed << " bytes outside every buffer view";
  ASSERT_EQ(blob->summary.mesh_node_names.size(), test::BuiltinCharacter().meshes.size());
  AiScene in(path);
  ASSERT_NE(in.scene, nullptr);
  for (size_t m = 0; m < test::BuiltinCharacter().meshes.size(); ++m) {
    const aiNode* node = in.scene->mRootNode->FindNode(blob->summary.mesh_node_names[m].c_str());
    ASSERT_NE(node, nullptr) << blob->summary.mesh_node_names[m];
    ASSERT_EQ(node->mNumMeshes, 1u);
    EXPECT_EQ(in.scene->mMeshes[node->mMeshes[0]]->mNumFaces, test::BuiltinCharacter().meshes[m].triangle_count);
  }
}

// A skeleton with clips and no mesh (an animation-only file) exports and reads back as nodes and
// animations.
TEST(GlbExporter, SkeletonAndClipsWithoutAMesh) {
  const RawCharacter c = WithoutMesh(MakeBuiltinCharacter());
  const auto path = test::TempDir("glb_exporter_no_mesh") / "anim.glb";
  const auto r = ExportGlb(c, path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->mesh_count, 0u);
  AiScene in(path);
  ASSERT_NE(in.scene, nullptr) << aiGetErrorString();
  EXPECT_EQ(in.scene->mNumMeshes, 0u);
  EXPECT_EQ(in.scene->mNumAnimations, c.clips.size());
  for (const auto& name : c.skeleton.joint_names)
    EXPECT_NE(in.scene->mRootNode->FindNode(name.c_str()), nullptr) << name;
}

// Repeated joint names (glTF allows them) get a suffix, and the file still plays the same.
TEST(GlbExporter, RepeatedJointNamesAreMadeUnique) {
  RawCharacter c = MakeBuiltinCharacter();
  c.skeleton.joint_names[static_cast<size_t>(c.skeleton.Find("LeftFoot"))] = "RightFoot";
  const auto path = test::TempDir("glb_exporter_repeated_names") / "twice.glb";
  const auto r = ExportGlb(c, path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const auto back = ImportCharacter(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_GE(back->skeleton.Find("RightFoot"), 0);
  EXPECT_GE(back->skeleton.Find("RightFoot_2"), 0);
  const auto& walk = c.clips[0];
  const auto a = test::PoseAt(c, walk, 0.3f), b = test::PoseAt(*back, back->clips[0], 0.3f);
  ASSERT_EQ(a.size(), b.size());
  float worst = 0.0f;
  for (size_t v = 0; v < a.size(); ++v) worst = std::max(worst, (a[v] - b[v]).norm());
  EXPECT_LT(worst, 2e-4f);
}

TEST(GlbExporter, RefusesInconsistentInputWithAMessage) {
  RawCharacter c = MakeBuiltinCharacter();
  c.skin.influence_offsets.pop_back();
  const auto path = test::TempDir("glb_exporter_bad") / "bad.glb";
  auto r = ExportGlb(c, path);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(r.error().message.find("bad.glb"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(path));

  RawCharacter d = MakeBuiltinCharacter();
  skinning::BindEntry extra = d.skin.binds[3];
  extra.inverse_bind(0, 3) += 0.5f;
  d.skin.binds.push_back(extra);
  r = ExportGlb(d, path);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("Spine1"), std::string::npos) << r.error().message;

  RawCharacter e = MakeBuiltinCharacter();
  GlbExtras extras;
  extras.frame_times_s = {0.0f, 1.0f};
  extras.spheres.push_back(AnimatedSphere{{skinspheres::Vec4f(0, 0, 0, 1)}});
  r = ExportGlb(e, path, extras);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
}

TEST(GlbExporter, UnwritablePathIsAnErrorNotACrash) {
  const auto r =
      ExportGlb(test::BuiltinCharacter(), test::TempDir("glb_exporter_unwritable") / "no_such_dir" / "x.glb");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kFileUnreadable);
  EXPECT_NE(r.error().message.find("x.glb"), std::string::npos);
}

}  // namespace
}  // namespace skinspheres::lib
