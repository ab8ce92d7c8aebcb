// The module's sphere sets, assets and instances (module_internal.h): load, fit, and one
// character's per-frame state.
#include "module_internal.h"
#include "skinspheres/runtime/fix/pose_fixer.h"

namespace skinspheres::python {

PySphereSet Load(const PathText& path_arg) {
  const std::string& path = path_arg.value;
  runtime::SphereSet set;
  {
    py::gil_scoped_release release;
    auto read = runtime::LoadSphereSet(path);
    if (!read.ok()) Throw(read.error());
    set = std::move(read).value();
  }
  return {std::make_shared<const runtime::SphereSet>(std::move(set)), {}};
}

tool::FitOptions Resolved(tool::FitOptions options) {
  if (auto why = options.Resolve()) ThrowArgument(*why);
  return options;
}

PySphereSet Fit(const std::optional<PathText>& path, const tool::FitOptions& fit_options) {
  const tool::FitOptions options = Resolved(fit_options);
  lib::FitResult fit;
  double import_seconds = 0.0;
  {
    py::gil_scoped_release release;
    auto loaded = tool::LoadCharacter(path ? path->value : std::string(), options.parts_file);
    if (!loaded.ok()) Throw(loaded.error());
    import_seconds = loaded->import_seconds;
    auto result = lib::FitSpheres(loaded->character, loaded->parts, options.settings);
    if (!result.ok()) Throw(result.error());
    fit = std::move(result).value();
  }
  py::dict report;
  report["seconds"] = fit.report.seconds;
  report["import_seconds"] = import_seconds;
  report["body_height"] = fit.report.body_height;
  report["standoff_before"] = fit.report.standoff_before;
  report["standoff_after"] = fit.report.standoff_after;
  report["spheres_split"] = fit.report.spheres_split;
  report["split_rounds"] = fit.report.split_rounds;
  report["triangles_covered"] = fit.report.triangles_covered;
  return {std::make_shared<const runtime::SphereSet>(std::move(fit.spheres)), report};
}

PyAsset MakeAsset(const PySphereSet& set, float margin, float touch_tolerance) {
  runtime::NarrowPhaseSettings narrow;
  narrow.margin = margin;
  narrow.touch_tolerance_share = touch_tolerance;
  runtime::SphereSet copy = *set.set;
  py::gil_scoped_release release;
  return {Take(runtime::CharacterAsset::Create(std::move(copy), narrow))};
}

PySphereSet SetOf(const PyAsset& a) {
  return {std::shared_ptr<const runtime::SphereSet>(a.asset, &a.asset->sphere_set()), {}};
}

PyInstance::PyInstance(const PyAsset& asset, const std::optional<std::vector<std::string>>& joint_names)
    : asset_(asset.asset) {
  if (joint_names) {
    mapping_ = Take(runtime::MapJoints(asset_->sphere_set(), *joint_names));
    instance_.emplace(Take(runtime::CharacterInstance::Create(asset_, mapping_)));
  } else {
    instance_.emplace(Take(runtime::CharacterInstance::Create(asset_)));
  }
  world_.resize(instance_->joint_input_count());
}

void PyInstance::UpdateFast(const py::handle& world) {
  Busy busy(this);
  ReadMatrices(world, "world", &world_);
  Check(Released([&] { return instance_->UpdateFast(world_); }));
}

void PyInstance::UpdateExact(const py::handle& positions, const py::handle& world) {
  Busy busy(this);
  ReadPositions(positions);
  std::span<const Mat4f> joints;
  if (!world.is_none()) {
    ReadMatrices(world, "world", &world_);
    joints = world_;
  }
  Check(Released([&] { return instance_->UpdateExact(positions_, joints); }));
}

py::array PyInstance::SpherePairs() {
  Busy busy(this);
  std::span<const runtime::SpherePair> pairs;
  {
    py::gil_scoped_release release;
    pairs = instance_->FindSpherePairs();
  }
  Check(instance_->status());
  return SpherePairArray(pairs);
}

py::tuple PyInstance::Contacts(const py::handle& positions) {
  Busy busy(this);
  std::span<const Eigen::Vector3f> skinned;
  if (!positions.is_none()) {
    ReadPositions(positions);
    skinned = positions_;
  }
  Check(Released([&] { return instance_->FindContacts(skinned); }));
  return ContactArrays(instance_->contacts());
}

// The per-frame loop of a C++ engine on these frames (update_fast, sphere pairs, contacts when
// asked), with no Python between frames: what bench/python_overhead.py sets the Python loop
// against. Returns seconds per frame (the matrices are read before the clock starts).
double PyInstance::CppFrameLoop(const py::handle& worlds, bool contacts, int repeats) {
  Busy busy(this);
  const FloatArray a = ReadFloatArray(worlds, "worlds", {-1, -1, 4, 4});
  const size_t frames = static_cast<size_t>(a.shape[0]), joints = instance_->joint_input_count();
  if (frames == 0 || static_cast<size_t>(a.shape[1]) < joints || repeats < 1) {
    ThrowArgument("worlds: (F >= 1, J >= joint_count, 4, 4) and repeats >= 1");
  }
  std::vector<Mat4f> all(frames * joints);
  for (size_t f = 0; f < frames; ++f) {
    for (size_t j = 0; j < joints; ++j) {
      for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) {
          all[f * joints + j](r, c) = a.At({static_cast<py::ssize_t>(f), static_cast<py::ssize_t>(j), r, c});
        }
      }
    }
  }
  py::gil_scoped_release release;
  size_t checksum = 0;
  const auto start = std::chrono::steady_clock::now();
  for (int rep = 0; rep < repeats; ++rep) {
    for (size_t f = 0; f < frames; ++f) {
      Check(instance_->UpdateFast(std::span<const Mat4f>(all.data() + f * joints, joints)));
      checksum += instance_->FindSpherePairs().size();
      if (contacts) {
        Check(instance_->FindContacts());
        checksum += instance_->contacts().triangle_pairs.size();
      }
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (checksum == static_cast<size_t>(-1)) std::abort();  // keeps the loop's results alive
  return seconds / (static_cast<double>(frames) * repeats);
}

py::array PyInstance::Spheres() {
  Busy busy(this);
  const auto spheres = instance_->spheres();
  if (!instance_->spheres_valid()) Check(instance_->status());
  py::array_t<float> out({static_cast<py::ssize_t>(spheres.size()), py::ssize_t{4}});
  if (!spheres.empty()) std::memcpy(out.mutable_data(), spheres.data(), spheres.size() * sizeof(Vec4f));
  return out;
}

void PyInstance::Check(const runtime::FrameStatus& status) {
  if (!status.ok()) Throw(Error{status.code, status.message ? status.message : ToString(status.code)});
}

void PyInstance::ReadMatrices(const py::handle& object, const char* what, std::vector<Mat4f>* out) const {
  const FloatArray a = ReadFloatArray(object, what, {-1, 4, 4});
  const size_t need = instance_->joint_input_count();
  if (static_cast<size_t>(a.shape[0]) < need) {
    ThrowArgument(std::string(what) + ": " + std::to_string(a.shape[0]) + " matrices, the instance reads " +
                  std::to_string(need));
  }
  out->resize(need);
  for (size_t j = 0; j < need; ++j) {
    Mat4f& m = (*out)[j];
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) m(r, c) = a.At({static_cast<py::ssize_t>(j), r, c});
    }
  }
}

void PyInstance::ReadPositions(const py::handle& object) {
  const FloatArray a = ReadFloatArray(object, "positions", {-1, 3});
  const size_t need = asset_->source_vertex_count();
  if (static_cast<size_t>(a.shape[0]) < need) {
    ThrowArgument("positions: " + std::to_string(a.shape[0]) + " vertices, the set was fitted on " +
                  std::to_string(need));
  }
  positions_.resize(need);
  for (size_t v = 0; v < need; ++v) {
    for (int c = 0; c < 3; ++c) positions_[v][c] = a.At({static_cast<py::ssize_t>(v), c});
  }
}

py::tuple FixPose(const PyAsset& asset, const py::handle& locals_array, float max_depth) {
  const size_t joints = asset.asset->sphere_set().joint_count();
  const FloatArray in = ReadFloatArray(locals_array, "locals", {static_cast<py::ssize_t>(joints), 10});
  std::vector<skinning::Transform> locals(joints);
  for (size_t j = 0; j < joints; ++j) {
    auto at = [&](py::ssize_t k) { return in.At({static_cast<py::ssize_t>(j), k}); };
    locals[j].translation = Eigen::Vector3f(at(0), at(1), at(2));
    locals[j].rotation = Quatf(at(6), at(3), at(4), at(5));
    locals[j].scale = Eigen::Vector3f(at(7), at(8), at(9));
  }
  runtime::PoseFixResult result;
  {
    py::gil_scoped_release release;
    auto fixer = Take(runtime::PoseFixer::Create(asset.asset));
    runtime::PoseSolveSettings settings;
    settings.max_depth = max_depth;
    result = Take(fixer.Fix(locals, settings));
  }
  py::array_t<float> out({static_cast<py::ssize_t>(joints), py::ssize_t{10}});
  auto m = out.mutable_unchecked<2>();
  for (size_t j = 0; j < joints; ++j) {
    const auto& t = locals[j];
    const float values[10] = {t.translation.x(), t.translation.y(), t.translation.z(), t.rotation.x(), t.rotation.y(),
                              t.rotation.z(),    t.rotation.w(),    t.scale.x(),       t.scale.y(),    t.scale.z()};
    for (py::ssize_t k = 0; k < 10; ++k) m(static_cast<py::ssize_t>(j), k) = values[k];
  }
  py::dict info;
  info["holds"] = result.holds;
  info["steps"] = result.steps;
  info["deepest_before"] = result.deepest_before;
  info["deepest_after"] = result.deepest_after;
  return py::make_tuple(out, info);
}

}  // namespace skinspheres::python
