// The module's play and check (module_internal.h): the tool's own code, so results are the CLI's.
#include "module_internal.h"

namespace skinspheres::python {

namespace {

// What play() returns: per-frame arrays with a `frame` field, built from the frame sink's calls.
struct PlayCollect {
  std::vector<float> times, clip_times;
  std::vector<FrameSpherePairRecord> sphere_pairs;
  std::vector<FramePartContactRecord> parts;
  std::vector<FrameTriangleContactRecord> triangles;
};

// With a clip file, `clip` names or counts the file's clips (appended after the character's own
// `own` clips, renamed "<file stem>/<name>" where the name was taken): the first it selects.
size_t FileClip(const lib::RawCharacter& character, size_t own, const std::string& file, const std::string& clip) {
  auto chosen = tool::SelectClips(character, own, clip);
  if (!chosen.ok()) Throw(Error{chosen.error().code, file + ": " + chosen.error().message});
  return chosen->front();
}

// A command's JSON report as a dict with its exit code; raises `error` when there is no report.
py::dict ReportDict(const nlohmann::json& report, int exit_code, const Error& error) {
  if (report.is_null()) Throw(error);
  py::dict out =
      py::module_::import("json").attr("loads")(report.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  out["exit_code"] = exit_code;
  return out;
}

}  // namespace

tool::ClipFileOptions ClipFiles(const std::vector<std::string>& files, const std::string& joint_map,
                                const std::string& source_rest, const std::string& retarget,
                                const std::string& rest_directions) {
  tool::ClipFileOptions out;
  out.files = files;
  out.joint_map = joint_map;
  out.source_rest = source_rest;
  out.retarget = retarget;
  out.rest_directions = rest_directions;
  return out;
}

std::vector<std::string> ClipNames(const PathText& path_arg) {
  const std::string& path = path_arg.value;
  std::vector<std::string> names;
  py::gil_scoped_release release;
  auto file = lib::ReadAnimationFile(path);
  if (!file.ok()) Throw(file.error());
  for (const auto& clip : file->clips) names.push_back(clip.name);
  return names;
}

py::dict Play(const std::optional<std::string>& character, const PlayArgs& a) {
  if (a.mode != "exact" && a.mode != "fast") ThrowArgument("mode must be 'exact' or 'fast' (got '" + a.mode + "')");
  if (!(a.fps > 0.0f) || a.fps > 10000.0f) ThrowArgument("fps must be in (0, 10000]");
  if (a.frames < 0) ThrowArgument("frames must be >= 0 (0: the whole clip)");
  if (auto why = tool::CheckTouchTolerance(a.touch_tolerance)) ThrowArgument(*why);
  const tool::FitOptions fit_options = Resolved(tool::FitOptions{});  // as `play` fits on the fly
  PlayCollect got;
  std::string clip_name;
  std::vector<std::string> notes, part_names;
  float body_height = 0.0f, tolerance = 0.0f;
  int frame_count = 0;
  {
    py::gil_scoped_release release;
    auto loaded = tool::LoadCharacter(character.value_or(""), fit_options.parts_file);
    if (!loaded.ok()) Throw(loaded.error());
    const tool::ClipFileOptions files = ClipFiles(a.clip_files, a.joint_map, a.source_rest, a.retarget, "keep");
    const size_t own_clips = loaded->character.clips.size();
    if (auto why = tool::AddClipFiles(*loaded, files, a.fps, &notes)) Throw(*why);
    runtime::SphereSet set;
    if (a.spheres) {
      set = Take(runtime::LoadSphereSet(*a.spheres));
      tool::AttachMesh(loaded->character, &set);
    } else {
      set = Take(lib::FitSpheres(loaded->character, loaded->parts, fit_options.settings)).spheres;
    }
    const size_t clip = a.clip_files.empty() ? Take(tool::FindClip(loaded->character, a.clip))
                                             : FileClip(loaded->character, own_clips, a.clip_files.front(), a.clip);
    clip_name = loaded->character.clips[clip].name;
    tool::PlayOptions options;
    options.fps = a.fps;
    options.frames = a.frames;
    options.fast = a.mode == "fast";
    options.margin = a.margin;
    options.touch_tolerance = a.touch_tolerance;
    auto result = tool::PlayClip(*loaded, set, clip, options, [&](const tool::FrameView& f) {
      const auto frame = static_cast<uint32_t>(f.index);
      got.times.push_back(f.time_s);
      got.clip_times.push_back(f.clip_time_s);
      for (const auto& p : f.sphere_pairs) {
        got.sphere_pairs.push_back(WithFrame<FrameSpherePairRecord>(frame, ToRecord(p)));
      }
      const size_t first_part = got.parts.size(), first_triangle = got.triangles.size();
      for (size_t k = 0; k < f.contacts->parts.size(); ++k) {
        const runtime::PartContact& pc = f.contacts->parts[k];
        PartContactRecord r = ToRecord(pc);
        r.first_triangle_pair = static_cast<uint32_t>(first_triangle + pc.first_triangle_pair);
        got.parts.push_back(WithFrame<FramePartContactRecord>(frame, r));
        for (uint32_t q = pc.first_triangle_pair; q < pc.first_triangle_pair + pc.triangle_pair_count; ++q) {
          got.triangles.push_back(WithFrame<FrameTriangleContactRecord>(
              frame, ToRecord(f.contacts->triangle_pairs[q], static_cast<uint32_t>(first_part + k))));
        }
      }
      body_height = f.body_height;
      tolerance = f.touch_tolerance;
    });
    if (!result.ok()) Throw(result.error());
    frame_count = result->frames;
    part_names = PartNames(set);
  }
  py::dict out;
  out["clip"] = Text(clip_name);
  out["frames"] = frame_count;
  out["times"] = CopyArray(got.times);
  out["clip_times"] = CopyArray(got.clip_times);
  out["sphere_pairs"] = CopyArray(got.sphere_pairs);
  out["part_contacts"] = CopyArray(got.parts);
  out["triangle_contacts"] = CopyArray(got.triangles);
  out["part_names"] = Texts(part_names);
  out["body_height"] = body_height;
  out["touch_tolerance"] = tolerance;
  out["notes"] = Texts(notes);
  return out;
}

py::dict Retarget(const std::string& character, const tool::ClipFileOptions& files, const std::string& output,
                  const std::string& clip, float fps) {
  tool::RetargetWritten written;
  {
    py::gil_scoped_release release;
    written = Take(tool::WriteRetargetedClips(character, files, clip, fps, output));
  }
  py::dict out;
  out["output"] = Text(output);
  out["clips"] = Texts(written.clips);
  out["durations"] = CopyArray(written.durations);
  out["frames"] = written.frames;
  out["joints"] = written.joints;
  out["notes"] = Texts(written.notes);
  return out;
}

py::dict Check(tool::CheckArgs a) {
  tool::CheckOutcome outcome;
  {
    py::gil_scoped_release release;
    outcome = tool::RunCheck(a, /*quiet=*/true);
  }
  return ReportDict(outcome.report, outcome.exit_code, Error{outcome.error_code, outcome.error});
}

py::dict Fix(const std::string& character, const std::vector<std::string>& clip_files, const std::string& output,
             const FixArgs& args) {
  tool::FixArgs a;
  a.input = character;
  a.output = output;
  a.clip_files = ClipFiles(clip_files, args.joint_map, args.source_rest, args.retarget, "keep");
  a.clip = args.clip;
  a.allow = args.allow;
  a.max_depth = args.max_depth;
  a.spheres = args.spheres.value_or("");
  a.fps = args.fps;
  a.ease_s = args.ease;
  a.max_rotation_deg = args.max_rotation;
  a.max_jerk_ratio = args.max_jerk_ratio;
  a.jobs = args.jobs;
  tool::FixOutcome outcome;
  {
    py::gil_scoped_release release;
    outcome = tool::RunFix(a, /*quiet=*/true);
  }
  return ReportDict(outcome.report, outcome.exit_code, Error{outcome.error_code, outcome.error});
}

}  // namespace skinspheres::python

namespace skinspheres::python {

py::dict Colliders(tool::CollidersArgs a) {
  tool::CollidersOutcome outcome;
  {
    py::gil_scoped_release release;
    outcome = tool::RunColliders(a, /*quiet=*/true);
  }
  py::dict out = ReportDict(outcome.report, outcome.exit_code, Error{outcome.error_code, outcome.error});
  const auto n = static_cast<py::ssize_t>(outcome.colliders.size());
  py::array_t<uint32_t> joint(n);
  py::array_t<float> head({n, py::ssize_t{3}}), tail({n, py::ssize_t{3}}), head_radius(n), tail_radius(n);
  py::list part;
  for (py::ssize_t s = 0; s < n; ++s) {
    const lib::Collider& c = outcome.colliders[static_cast<size_t>(s)];
    joint.mutable_at(s) = c.joint;
    for (py::ssize_t k = 0; k < 3; ++k) head.mutable_at(s, k) = c.head[k], tail.mutable_at(s, k) = c.tail[k];
    head_radius.mutable_at(s) = c.head_radius;
    tail_radius.mutable_at(s) = c.tail_radius;
    part.append(c.part);
  }
  py::array_t<float> rest({static_cast<py::ssize_t>(outcome.joint_rest_world.size()), py::ssize_t{4}, py::ssize_t{4}});
  for (size_t j = 0; j < outcome.joint_rest_world.size(); ++j) {
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c)
        rest.mutable_at(static_cast<py::ssize_t>(j), r, c) = outcome.joint_rest_world[j](r, c);
    }
  }
  out["joint"] = joint;
  out["head"] = head;
  out["tail"] = tail;
  out["head_radius"] = head_radius;
  out["tail_radius"] = tail_radius;
  out["part"] = part;
  out["joint_names"] = outcome.joint_names;
  out["joint_rest_world"] = rest;
  return out;
}

}  // namespace skinspheres::python
