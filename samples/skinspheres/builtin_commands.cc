// skinspheres demo / skinspheres export-builtin OUT.glb|OUT.fbx [--no-mesh] [--no-clips] [--joint-prefix P]
//   [--armature-scale S] [--rotate-frames SEED] [--bone-scale S]
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "html_page.h"
#include "playback.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/character/rig_variants.h"
#include "skinspheres/lib/io/clip_import.h"
#include "skinspheres/lib/io/glb_exporter.h"

namespace skinspheres::tool {
namespace {

struct ExportBuiltinArgs {
  std::string output, joint_prefix;
  bool no_mesh = false, no_clips = false;
  float armature_scale = 1.0f;
  float bone_scale = 1.0f;
  int64_t rotate_frames = -1;  // a seed; < 0: the frames as they are
};

// The same character as a rig in other units: the root joint scaled by s, every other joint's
// translations (rest and keys) divided by s, inverse bind matrices from the new rest pose. The
// world shape and motion do not change (as Mixamo's centimetre rigs under a 0.01 armature).
void ScaleArmature(lib::RawCharacter& ch, float s) {
  auto& sk = ch.skeleton;
  for (size_t j = 0; j < sk.size(); ++j) {
    if (sk.parents[j] < 0) {
      sk.rest_local[j].scale *= s;
    } else {
      sk.rest_local[j].translation /= s;
    }
  }
  for (auto& clip : ch.clips) {
    for (auto& tr : clip.tracks) {
      if (sk.parents[static_cast<size_t>(tr.joint)] >= 0) {
        for (auto& v : tr.translation.values) v /= s;
      }
    }
  }
  std::vector<Mat4f> world(sk.size());
  sk.RestWorld(world);
  for (auto& b : ch.skin.binds) b.inverse_bind = world[static_cast<size_t>(b.joint)].inverse();
  // The scaled root binds no vertex: drop its bind entry, so it is a plain node above the skin's
  // joints (as an armature node is), not a joint of the skin.
  auto& skin = ch.skin;
  for (size_t b = skin.binds.size(); b-- > 0;) {
    if (sk.parents[static_cast<size_t>(skin.binds[b].joint)] >= 0) continue;
    if (std::find(skin.influence_binds.begin(), skin.influence_binds.end(), b) != skin.influence_binds.end()) continue;
    skin.binds.erase(skin.binds.begin() + static_cast<std::ptrdiff_t>(b));
    for (auto& k : skin.influence_binds) k = static_cast<uint16_t>(k > b ? k - 1 : k);
  }
}

int RunExportBuiltin(const ExportBuiltinArgs& a) {
  if (!(a.armature_scale > 0.0f) || !std::isfinite(a.armature_scale)) {
    return Fail("--armature-scale must be a positive number (got " + std::to_string(a.armature_scale) + ")");
  }
  if (!(a.bone_scale > 0.0f) || !std::isfinite(a.bone_scale)) {
    return Fail("--bone-scale must be a positive number (got " + std::to_string(a.bone_scale) + ")");
  }
  if (a.rotate_frames > int64_t{UINT32_MAX}) return Fail("--rotate-frames takes a seed from 0 to 4294967295");
  lib::RawCharacter ch = lib::MakeBuiltinCharacter();
  // Other rigs of the same character (lib/character/rig_variants.h): the tests' oracle for retargeting.
  if (a.bone_scale != 1.0f) lib::ScaleBones(ch, a.bone_scale);
  if (a.rotate_frames >= 0) {
    if (auto err = lib::RotateJointFrames(ch, static_cast<uint32_t>(a.rotate_frames))) return Fail(err->message);
  }
  if (a.armature_scale != 1.0f) ScaleArmature(ch, a.armature_scale);
  if (a.no_mesh) ch = lib::WithoutMesh(std::move(ch));  // an animation-only file, as Mixamo's "without skin"
  if (a.no_clips) ch.clips.clear();
  for (auto& name : ch.skeleton.joint_names) name = a.joint_prefix + name;
  std::string ext = std::filesystem::path(a.output).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  Result<lib::GlbExportSummary> written = MakeError(ErrorCode::kInvalidArgument, "");
  if (ext == ".glb") {
    written = lib::ExportGlb(ch, a.output);
  } else if (ext == ".fbx") {
    written = lib::ExportFbxAscii(ch, a.output);
  } else {
    return Fail(a.output + ": export-builtin writes .glb or .fbx (ASCII FBX 7.4), not \"" + ext + "\"");
  }
  if (!written.ok()) return Fail(written.error().message);
  std::printf("wrote %s: %zu vertices, %zu triangles, %zu joints, %zu clips\n", a.output.c_str(), ch.vertex_count(),
              ch.triangle_count(), ch.skeleton.size(), ch.clips.size());
  return 0;
}

// The demo's hands on the chest and on the head, in one clip: a hand touches when a contact's
// arm-side triangle belongs to a sphere whose dominant joint is a hand (or a finger under it):
// real triangle contacts, not overlapping spheres.
class HandTouches {
 public:
  explicit HandTouches(const runtime::SphereSet& set) : set_(set), owner_(set.source_triangle_count, UINT32_MAX) {
    for (uint32_t s = 0; s < set.size(); ++s) {
      for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) owner_[set.triangles[k]] = s;
      // A cut triangle (docs/TRIANGLE_PIECES.md): the lowest sphere owning one of its pieces.
      for (const runtime::TrianglePiece& p : set.PiecesOf(s)) owner_[p.triangle] = std::min(owner_[p.triangle], s);
    }
    targets_[0] = PartNamed("torso");
    targets_[1] = PartNamed("head");
  }

  // Starts a clip's counts.
  void Reset() {
    for (Touches& t : on_) t = Touches{};
  }

  void Frame(const FrameView& fr) {
    for (int target = 0; target < 2; ++target) {
      const int part = targets_[target];
      bool touching = false;
      float depth = 0.0f;
      for (const runtime::PartContact& p : fr.contacts->parts) {
        if (p.part_a != part && p.part_b != part) continue;
        for (uint32_t k = p.first_triangle_pair; k < p.first_triangle_pair + p.triangle_pair_count; ++k) {
          const runtime::TriangleContact& tp = fr.contacts->triangle_pairs[k];
          const uint32_t other = p.part_a == part ? tp.triangle_b : tp.triangle_a;
          if (tp.kind == runtime::TriangleContactKind::kIntersecting && IsHand(other)) {
            touching = true;
            depth = std::max(depth, p.depth);
          }
        }
      }
      if (!touching) continue;
      Touches& t = on_[target];
      if (t.frames++ == 0) t.first = fr.index, t.first_t = fr.clip_time_s;
      t.last = fr.index;
      t.last_t = fr.clip_time_s;
      t.depth = std::max(t.depth, depth);
    }
  }

  void Print() const {
    for (int target = 0; target < 2; ++target) {
      const char* label = target == 0 ? "chest" : "head";
      const Touches& t = on_[target];
      if (t.frames == 0) {
        std::printf("  hands on the %s: never\n", label);
      } else {
        std::printf("  hands on the %s: %zu frames, first %d (t=%.2f s), last %d (t=%.2f s), up to %.3g deep\n", label,
                    t.frames, t.first, t.first_t, t.last, t.last_t, t.depth);
      }
    }
  }

 private:
  struct Touches {
    size_t frames = 0;
    int first = -1, last = -1;
    float first_t = 0.0f, last_t = 0.0f;
    float depth = 0.0f;
  };

  bool IsHand(uint32_t triangle) const {
    const uint32_t s = owner_[triangle];
    return s != UINT32_MAX && set_.joint_names[set_.sphere_joint[s]].find("Hand") != std::string::npos;
  }
  int PartNamed(const char* name) const {
    for (size_t k = 0; k < set_.parts.size(); ++k) {
      if (set_.parts[k].name == name) return static_cast<int>(k);
    }
    return -1;
  }

  const runtime::SphereSet& set_;
  std::vector<uint32_t> owner_;  // the sphere owning each source triangle, UINT32_MAX for none
  int targets_[2];               // the torso's and the head's part
  Touches on_[2];                // chest, head
};

// skinspheres demo: fits the built-in character, plays every clip with --verify's checks and the
// hands' touches, and writes the viewer page to `html`.
int RunDemo(FitOptions& opts, const std::string& html) {
  if (auto why = opts.Resolve()) return Fail(*why);
  auto loaded = LoadCharacter("", opts.parts_file);
  if (!loaded.ok()) return Fail(loaded.error().message);
  auto fit = lib::FitSpheres(loaded->character, loaded->parts, opts.settings);
  if (!fit.ok()) return Fail(fit.error().message);
  std::printf("built-in character: %zu vertices, %zu triangles, %zu joints, clips:", loaded->character.vertex_count(),
              loaded->character.triangle_count(), loaded->character.skeleton.size());
  for (const auto& c : loaded->character.clips) std::printf(" %s (%.2f s)", c.name.c_str(), c.duration_s);
  std::printf("\n");
  PrintFitSummary(*fit, loaded->import_seconds);
  const runtime::SphereSet& set = fit->spheres;
  HandTouches touches(set);
  bool all_verified = true;
  std::vector<PlayResult> kept;                  // for the page
  std::vector<std::vector<FrameRecord>> frames;  // the page's per-frame data
  kept.reserve(loaded->character.clips.size());
  frames.reserve(loaded->character.clips.size());
  for (size_t c = 0; c < loaded->character.clips.size(); ++c) {
    touches.Reset();
    PlayOptions play;
    play.verify = true;
    const FrameSink sink = [&](const FrameView& fr) { touches.Frame(fr); };
    frames.emplace_back();
    auto played = PlayClip(*loaded, set, c, play, RecordFrames(&frames.back(), sink));
    if (!played.ok()) return Fail(played.error().message);
    std::printf("\n");
    PrintPlaySummary(*played, set, play.fps, /*sphere_pairs=*/false, /*verify=*/true);
    touches.Print();
    all_verified &= played->verified();
    kept.push_back(std::move(*played));
  }
  ViewerPageInput page{&*loaded, &set, fit->report.seconds, {}, {}, nullptr};
  for (size_t c = 0; c < kept.size(); ++c)
    page.clips.push_back(ViewClip{&kept[c], &frames[c], c, PlayOptions{}.fps, false});
  if (auto err = WriteViewerPage(page, html)) return Fail(err->message);
  std::printf("\npage: %s (open it in a browser; it needs no server or network)\n",
              std::filesystem::absolute(html).string().c_str());
  return all_verified ? 0 : 1;
}

}  // namespace

void AddExportBuiltinCommand(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<ExportBuiltinArgs>();
  CLI::App* cmd =
      app.add_subcommand("export-builtin", "write the built-in character (mesh, skin, clips) as GLB or FBX");
  cmd->add_option("output", args->output, "file to write: .glb, or .fbx (ASCII FBX 7.4)")->required();
  cmd->add_flag("--no-mesh", args->no_mesh,
                "write the skeleton and clips only (an animation-only file, for play --clips)");
  cmd->add_flag("--no-clips", args->no_clips, "write no animations (a character without clips)");
  cmd->add_option("--joint-prefix", args->joint_prefix, "put this before every joint name (e.g. mixamorig:)");
  cmd->add_option("--armature-scale", args->armature_scale,
                  "scale the root joint by this and divide bone translations by it: the same shape as a rig in "
                  "other units (0.01: centimetres under a metre armature)");
  cmd->add_option("--rotate-frames", args->rotate_frames,
                  "turn every joint's local frame by a rotation drawn from this seed, keeping the world rest pose "
                  "and motion: the same character as a rig with other rest frames");
  cmd->add_option("--bone-scale", args->bone_scale,
                  "scale the whole rig and mesh by this (bones this many times as long, the same rotations)");
  cmd->callback([args, exit_code] { *exit_code = RunExportBuiltin(*args); });
}

void AddDemoCommand(CLI::App& app, int* exit_code) {
  auto opts = std::make_shared<FitOptions>();
  auto html =
      std::make_shared<std::string>((std::filesystem::temp_directory_path() / "skinspheres-demo.html").string());
  CLI::App* cmd = app.add_subcommand("demo", "fit the built-in character and play its clips");
  opts->AddTo(*cmd);
  cmd->add_option("--html", *html, "where to write the viewer page")->capture_default_str();
  cmd->callback([opts, html, exit_code] { *exit_code = RunDemo(*opts, *html); });
}

}  // namespace skinspheres::tool
