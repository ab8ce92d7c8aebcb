// WriteViewerPage (html_page.h): the page data as JSON ("skinspheres.view" version 1, see
// docs/VIEWER.md), the character as GLB (base64), both inlined with the viewer's scripts into
// the template viewer/index.html.
#include "html_page.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string_view>

#include "skinspheres/lib/io/glb_exporter.h"
#include "skinspheres/lib/metrics/fit_metrics.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/skinning/sampling_job.h"
#include "viewer_assets.h"

namespace skinspheres::tool {
namespace {

using nlohmann::json;

std::string Base64(const void* data, size_t size) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = static_cast<const uint8_t*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (size_t i = 0; i < size; i += 3) {
    const uint32_t b0 = p[i], b1 = i + 1 < size ? p[i + 1] : 0, b2 = i + 2 < size ? p[i + 2] : 0;
    const uint32_t v = b0 << 16 | b1 << 8 | b2;
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += i + 1 < size ? kAlphabet[v >> 6 & 63] : '=';
    out += i + 2 < size ? kAlphabet[v & 63] : '=';
  }
  return out;
}

// Floats as base64 of their little-endian IEEE bytes (a Float32Array in the page).
std::string Base64Floats(const std::vector<float>& v) { return Base64(v.data(), v.size() * sizeof(float)); }

// Median and 95th percentile of per-frame seconds, in microseconds.
json StageMicroseconds(const StageTime& v) {
  if (v.count() == 0) return nullptr;
  return json{{"median_us", v.Percentile(0.5) * 1e6}, {"p95_us", v.Percentile(0.95) * 1e6}};
}

std::string EscapeHtml(std::string_view s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

// JSON text safe inside <script>: '<' only occurs inside JSON strings, where \u003c means the same.
std::string ScriptSafeJson(const json& j) {
  const std::string text = j.dump(-1, ' ', false, json::error_handler_t::replace);
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    if (c == '<') {
      out += "\\u003c";
    } else {
      out += c;
    }
  }
  return out;
}

bool HoldsScriptEnd(std::string_view script) {
  for (size_t k = script.find("</"); k != std::string_view::npos; k = script.find("</", k + 2)) {
    std::string tag(script.substr(k + 2, 6));
    std::transform(tag.begin(), tag.end(), tag.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (tag == "script") return true;
  }
  return false;
}

json CharacterJson(const lib::RawCharacter& ch, const lib::GlbExportSummary& glb) {
  json meshes = json::array();
  for (size_t m = 0; m < ch.meshes.size(); ++m) {
    const auto& r = ch.meshes[m];
    meshes.push_back({{"name", r.name},
                      {"node", m < glb.mesh_node_names.size() ? glb.mesh_node_names[m] : r.name},
                      {"first_triangle", r.first_triangle},
                      {"triangle_count", r.triangle_count},
                      {"first_vertex", r.first_vertex},
                      {"vertex_count", r.vertex_count},
                      {"skinned", r.skinned}});
  }
  json clips = json::array();
  for (const auto& c : ch.clips) clips.push_back({{"name", c.name}, {"duration", c.duration_s}});
  return {{"file", ch.source_file.empty() || ch.source_file == "<builtin>" ? "built-in character" : ch.source_file},
          {"vertices", ch.vertex_count()},
          {"triangles", ch.triangle_count()},
          {"joints", ch.skeleton.size()},
          {"meshes", std::move(meshes)},
          {"clips", std::move(clips)}};
}

json SpheresJson(const runtime::SphereSet& set) {
  std::vector<float> rest;
  json part = json::array(), joint = json::array(), triangles = json::array(), vertices = json::array(),
       level = json::array();
  for (size_t s = 0; s < set.size(); ++s) {
    rest.insert(rest.end(),
                {set.centers_rest[s].x(), set.centers_rest[s].y(), set.centers_rest[s].z(), set.radii_rest[s]});
    part.push_back(set.sphere_part[s]);
    joint.push_back(set.sphere_joint[s]);
    triangles.push_back(set.triangle_offsets[s + 1] - set.triangle_offsets[s]);
    vertices.push_back(set.vertex_offsets[s + 1] - set.vertex_offsets[s]);
    level.push_back(set.sphere_level.size() == set.size() ? set.sphere_level[s] : 0);
  }
  json excluded = json::array(), reasons = json::array();
  for (const auto& p : set.excluded_pairs) {
    excluded.push_back(p.i);
    excluded.push_back(p.j);
    reasons.push_back(static_cast<int>(p.reason));
  }
  json parts = json::array();
  for (const auto& p : set.parts) parts.push_back(p.name);
  // Triangle pieces (docs/TRIANGLE_PIECES.md), CSR: sphere s owns (triangle, level, index) triples
  // pieces[3 offsets[s] .. 3 offsets[s+1]).
  std::vector<uint32_t> pieces;
  for (const runtime::TrianglePiece& p : set.pieces) pieces.insert(pieces.end(), {p.triangle, p.level, p.index});
  const std::vector<uint32_t> piece_offsets =
      set.piece_offsets.empty() ? std::vector<uint32_t>(set.size() + 1, 0) : set.piece_offsets;
  return {{"count", set.size()},
          {"parts", std::move(parts)},
          {"joint_names", set.joint_names},
          {"part", std::move(part)},
          {"joint", std::move(joint)},
          {"level", std::move(level)},
          {"triangles", std::move(triangles)},
          {"vertices", std::move(vertices)},
          {"rest_xyzr", Base64Floats(rest)},
          // Owned triangles (source order), CSR: sphere s owns owned_triangles[offsets[s] .. offsets[s+1]).
          {"owned_offsets", Base64(set.triangle_offsets.data(), set.triangle_offsets.size() * sizeof(uint32_t))},
          {"owned_triangles", Base64(set.triangles.data(), set.triangles.size() * sizeof(uint32_t))},
          {"piece_offsets", Base64(piece_offsets.data(), piece_offsets.size() * sizeof(uint32_t))},
          {"pieces", Base64(pieces.data(), pieces.size() * sizeof(uint32_t))},
          {"excluded",
           {{"pairs", std::move(excluded)},
            {"reason", std::move(reasons)},
            {"reasons",
             {runtime::ToString(runtime::ExclusionReason::kSameJoint),
              runtime::ToString(runtime::ExclusionReason::kAdjacentJoints),
              runtime::ToString(runtime::ExclusionReason::kBindOverlap)}}}}};
}

json MetricsJson(const lib::FitMetrics& m, size_t spheres, double seconds) {
  // The loosest spheres: the largest shares of the mean boundary distance, as `fit --metrics` lists them.
  std::vector<size_t> order(m.sphere_boundary_distance.size());
  for (size_t s = 0; s < order.size(); ++s) order[s] = s;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return m.sphere_boundary_distance[a] > m.sphere_boundary_distance[b]; });
  json loosest = json::array();
  for (size_t k = 0; k < std::min<size_t>(5, order.size()); ++k) loosest.push_back(order[k]);
  std::vector<float> share(spheres, 0.0f);
  if (m.sphere_boundary_distance.size() == spheres && m.boundary_distance_mean > 0.0) {
    for (size_t s = 0; s < spheres; ++s)
      share[s] = static_cast<float>(m.sphere_boundary_distance[s] / m.boundary_distance_mean);
  }
  return {{"volume_ratio", m.volume_ratio},
          {"boundary_mean_rel", m.boundary_distance_mean_rel},
          {"boundary_max_rel", m.boundary_distance_max_rel},
          {"body_height", m.body_height},
          {"uncovered_triangles", m.uncovered_triangles},
          {"loosest", std::move(loosest)},
          {"share", Base64Floats(share)},
          {"seconds", seconds}};
}

Result<json> ClipJson(const ViewClip& vc, const lib::RawCharacter& ch, size_t spheres) {
  const PlayResult& r = *vc.played;
  if (vc.clip_index >= ch.clips.size())
    return MakeError(ErrorCode::kInvalidArgument, "viewer page: clip index out of range");
  const auto& clip = ch.clips[vc.clip_index];
  if (vc.frames == nullptr || vc.frames->size() != static_cast<size_t>(r.frames)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "viewer page: clip \"" + clip.name + "\" was played without keeping its frames");
  }
  const std::vector<FrameRecord>& frames = *vc.frames;
  std::vector<float> xyzr;
  xyzr.reserve(frames.size() * spheres * 4);
  json time = json::array(), clip_time = json::array(), pairs = json::array(), depths = json::array();
  json contact_pairs = json::array();
  json triangles = json::array(), part_contacts = json::array();
  for (const FrameRecord& f : frames) {
    if (f.spheres.size() != spheres) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "viewer page: clip \"" + clip.name + "\" has frames of another sphere set");
    }
    for (const auto& s : f.spheres) xyzr.insert(xyzr.end(), {s.x(), s.y(), s.z(), s.w()});
    time.push_back(f.time_s);
    clip_time.push_back(f.clip_time_s);
    json p = json::array(), d = json::array();
    for (const auto& c : f.sphere_pairs) {
      p.push_back(c.sphere_i);
      p.push_back(c.sphere_j);
      d.push_back(c.depth);
    }
    pairs.push_back(std::move(p));
    depths.push_back(std::move(d));
    json owners = json::array();
    for (const auto& c : f.contact_sphere_pairs) owners.insert(owners.end(), {c.i, c.j});
    contact_pairs.push_back(std::move(owners));
    json flat = json::array();
    for (const auto& tp : f.triangle_pairs) {
      if (tp[0] >= ch.triangle_count() || tp[1] >= ch.triangle_count()) {
        return MakeError(ErrorCode::kInvalidArgument, "viewer page: a triangle pair names a triangle past the mesh's " +
                                                          std::to_string(ch.triangle_count()));
      }
      flat.push_back(tp[0]);
      flat.push_back(tp[1]);
    }
    triangles.push_back(std::move(flat));
    json parts = json::array();  // part_a, part_b, kind (1 penetrating, 0 touching), depth
    for (const FrameRecord::Part& c : f.parts)
      parts.insert(parts.end(), {c.part_a, c.part_b, c.penetrating ? 1 : 0, c.depth});
    part_contacts.push_back(std::move(parts));
  }
  return json{{"name", clip.name},
              {"animation", clip.name},
              {"duration", clip.duration_s},
              {"fps", vc.fps},
              {"mode", vc.fast ? "fast" : "exact"},
              {"frames", frames.size()},
              {"time", std::move(time)},
              {"clip_time", std::move(clip_time)},
              {"spheres_xyzr", Base64Floats(xyzr)},
              {"pairs", std::move(pairs)},
              {"depths", std::move(depths)},
              {"contact_pairs", std::move(contact_pairs)},
              {"triangle_pairs", std::move(triangles)},
              {"part_contacts", std::move(part_contacts)},
              {"touch_tolerance", r.touch_tolerance},
              {"stages_us",
               {{"sample", StageMicroseconds(r.times.sample)},
                {"skin", StageMicroseconds(r.times.skin)},
                {"refit", StageMicroseconds(r.times.refit)},
                {"query", StageMicroseconds(r.times.query)},
                {"narrow", StageMicroseconds(r.times.narrow)}}}};
}

// Fills the template: every "{{NAME}}" is replaced once, in one pass (inserted text is never rescanned).
Result<std::string> FillTemplate(std::string_view tpl,
                                 const std::vector<std::pair<std::string_view, std::string_view>>& values) {
  std::string out;
  size_t at = 0;
  std::vector<int> used(values.size(), 0);
  for (size_t open = tpl.find("{{"); open != std::string_view::npos; open = tpl.find("{{", at)) {
    const size_t close = tpl.find("}}", open);
    if (close == std::string_view::npos) break;
    const std::string_view name = tpl.substr(open + 2, close - open - 2);
    const auto it = std::find_if(values.begin(), values.end(), [&](const auto& v) { return v.first == name; });
    if (it == values.end())
      return MakeError(ErrorCode::kInvalidArgument, "viewer page template: unknown {{" + std::string(name) + "}}");
    out.append(tpl.substr(at, open - at));
    out.append(it->second);
    ++used[static_cast<size_t>(it - values.begin())];
    at = close + 2;
  }
  out.append(tpl.substr(at));
  for (size_t k = 0; k < values.size(); ++k) {
    if (used[k] != 1)
      return MakeError(ErrorCode::kInvalidArgument,
                       "viewer page template: {{" + std::string(values[k].first) + "}} not used once");
  }
  return out;
}

}  // namespace

std::optional<Error> WriteViewerPage(const ViewerPageInput& in, const std::string& path) {
  const lib::RawCharacter& ch = in.loaded->character;
  const runtime::SphereSet& set = *in.set;
  const std::string label =
      ch.source_file.empty() || ch.source_file == "<builtin>" ? "built-in character" : ch.source_file;

  auto glb = lib::ExportGlbToMemory(ch, label);
  if (!glb.ok()) return glb.error();
  const auto t0 = std::chrono::steady_clock::now();
  auto metrics = lib::MeasureFit(ch, set);
  const double metrics_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!metrics.ok()) return MakeError(metrics.error().code, path + ": " + metrics.error().message);

  json data = {{"format", "skinspheres.view"},
               {"version", 1},
               {"kind", in.clips.empty() ? "fit" : "play"},
               {"three_revision", SKINSPHERES_THREE_REVISION},
               {"character", CharacterJson(ch, glb->summary)},
               {"spheres", SpheresJson(set)},
               {"metrics", MetricsJson(*metrics, set.size(), metrics_seconds)},
               {"timings",
                {{"import_ms", in.loaded->import_seconds * 1e3},
                 {"fit_ms", in.fit_seconds >= 0.0 ? json(in.fit_seconds * 1e3) : json(nullptr)},
                 {"metrics_ms", metrics_seconds * 1e3}}},
               {"notes", in.notes}};
  json clips = json::array();
  for (const ViewClip& vc : in.clips) {
    auto c = ClipJson(vc, ch, set.size());
    if (!c.ok()) return MakeError(c.error().code, path + ": " + c.error().message);
    clips.push_back(std::move(*c));
  }
  data["clips"] = std::move(clips);
  if (!in.colliders.is_null()) data["colliders"] = in.colliders;

  namespace va = viewer_assets;
  for (std::string_view script : {va::kThreeJs, va::kGltfLoaderJs, va::kOrbitControlsJs, va::kViewerJs}) {
    if (HoldsScriptEnd(script))
      return MakeError(ErrorCode::kInvalidArgument, path + ": an inlined script holds \"</script\"");
  }
  const std::string title = EscapeHtml(label);
  const std::string data_text = ScriptSafeJson(data);
  const std::string glb_text = Base64(glb->bytes.data(), glb->bytes.size());
  const std::string revision = SKINSPHERES_THREE_REVISION;
  auto page = FillTemplate(va::kIndexHtml, {{"TITLE", title},
                                            {"CSS", va::kViewerCss},
                                            {"THREE_REVISION", revision},
                                            {"THREE_LICENSE", va::kThreeLicense},
                                            {"THREE_JS", va::kThreeJs},
                                            {"GLTF_LOADER_JS", va::kGltfLoaderJs},
                                            {"ORBIT_CONTROLS_JS", va::kOrbitControlsJs},
                                            {"VIEWER_JS", va::kViewerJs},
                                            {"DATA", data_text},
                                            {"GLB", glb_text}});
  if (!page.ok()) return MakeError(page.error().code, path + ": " + page.error().message);
  return runtime::WriteWholeFile(path, *page);
}

}  // namespace skinspheres::tool
