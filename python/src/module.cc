// _skinspheres: the native part of the Python module `skinspheres` (python/skinspheres/__init__.py
// re-exports it; _skinspheres.pyi documents its types). It binds the C++ API directly: the fitter
// (fit), the sphere-set formats (load, SphereSet.save), the runtime (Asset, Instance), and the
// tool's own play and check code (play, check), so their results are the CLI's.
//
// Arrays: inputs are numpy arrays of float32 or float64 in any strides (transposed, sliced,
// non-contiguous), read element by element into the instance's buffers, which are sized once: a
// frame allocates only its output arrays. float64 becomes float32 by rounding to nearest, as
// numpy's astype does. Outputs are new numpy arrays (structured for pairs and contacts) that the
// caller owns. Matrices are (J, 4, 4) in the usual mathematical layout: world[j] @ [x, y, z, 1]
// moves a point, the translation is world[j, :3, 3].
//
// Threads: every call that runs more than a few microseconds releases the GIL (fit, play, check,
// the updates and the contact searches). An Instance is one character's state: using one from two
// threads at once raises (it is never a data race); distinct instances run in parallel.
//
// Errors: the library's one-line messages, as Python exceptions (skinspheres.Error and its
// subclasses, which also derive from the matching built-in: FileNotFoundError, ValueError, ...);
// wrong argument types raise TypeError.
//
// Files: module_internal.h (what they share), errors.cc, arrays.cc (numpy in and out), instance.cc
// (SphereSet, Asset, Instance), tools.cc (play, check), and this file: the binding table.
#include "module_internal.h"

namespace skinspheres::python {
namespace {

py::object g_contacts_type;  // collections.namedtuple("Contacts", "parts triangles")

}  // namespace
}  // namespace skinspheres::python

using namespace skinspheres;          // NOLINT(google-build-using-namespace): the module's definitions
using namespace skinspheres::python;  // NOLINT(google-build-using-namespace)
using namespace pybind11::literals;   // NOLINT(google-build-using-namespace)

PYBIND11_MODULE(_skinspheres, m) {
  m.doc() = "skinspheres: sphere sets for skinned characters and their self-contacts (native part).";
  m.attr("__version__") = SKINSPHERES_VERSION_STRING;
  RegisterErrors(m);

  PYBIND11_NUMPY_DTYPE(SpherePairRecord, sphere_i, sphere_j, depth, part_i, part_j);
  PYBIND11_NUMPY_DTYPE(PartContactRecord, part_a, part_b, kind, depth, min_distance, normal, center, triangle_pairs,
                       intersecting, sphere_pairs, first_triangle_pair);
  PYBIND11_NUMPY_DTYPE(TriangleContactRecord, part_contact, triangle_a, triangle_b, kind, distance, point, on_a, on_b);
  PYBIND11_NUMPY_DTYPE(FrameSpherePairRecord, frame, sphere_i, sphere_j, depth, part_i, part_j);
  PYBIND11_NUMPY_DTYPE(FramePartContactRecord, frame, part_a, part_b, kind, depth, min_distance, normal, center,
                       triangle_pairs, intersecting, sphere_pairs, first_triangle_pair);
  PYBIND11_NUMPY_DTYPE(FrameTriangleContactRecord, frame, part_contact, triangle_a, triangle_b, kind, distance, point,
                       on_a, on_b);
  m.attr("SPHERE_PAIR_DTYPE") = py::dtype::of<SpherePairRecord>();
  m.attr("PART_CONTACT_DTYPE") = py::dtype::of<PartContactRecord>();
  m.attr("TRIANGLE_CONTACT_DTYPE") = py::dtype::of<TriangleContactRecord>();
  m.attr("FRAME_SPHERE_PAIR_DTYPE") = py::dtype::of<FrameSpherePairRecord>();
  m.attr("FRAME_PART_CONTACT_DTYPE") = py::dtype::of<FramePartContactRecord>();
  m.attr("FRAME_TRIANGLE_CONTACT_DTYPE") = py::dtype::of<FrameTriangleContactRecord>();
  m.attr("TOUCHING") = 0;
  m.attr("PENETRATING") = 1;
  m.attr("INTERSECTING") = 0;
  m.attr("WITHIN_MARGIN") = 1;
  m.attr("DEFAULT_TOUCH_TOLERANCE") = tool::kDefaultTouchTolerance;
  g_masked_array_type = py::module_::import("numpy.ma").attr("MaskedArray");
  g_contacts_type = py::module_::import("collections").attr("namedtuple")("Contacts", "parts triangles");
  g_contacts_type.attr("__module__") = "skinspheres";
  m.attr("Contacts") = g_contacts_type;
  // The namedtuple outlives the interpreter's last reference only through this capsule.
  m.add_object("_cleanup", py::capsule([] {
                 g_contacts_type.release();
                 g_masked_array_type.release();
               }));

  py::class_<PySphereSet>(m, "SphereSet", "A fitted sphere set: spheres in the rest pose, their parts and joints.")
      .def("__len__", [](const PySphereSet& s) { return s.set->size(); })
      .def("__repr__",
           [](const PySphereSet& s) {
             return "<skinspheres.SphereSet " + std::to_string(s.set->size()) + " spheres, " +
                    std::to_string(s.set->parts.size()) + " parts, " + std::to_string(s.set->joint_count()) +
                    " joints, fitted on '" + std::string(py::str(Text(s.set->source_file))) + "'>";
           })
      .def(
          "save",
          [](const PySphereSet& s, const PathText& path, bool fast_only) {
            std::optional<std::string> why;
            {
              py::gil_scoped_release release;
              why = tool::SaveSetFile(*s.set, path.value, fast_only);
            }
            if (why) ThrowArgument(*why);
          },
          "path"_a, py::kw_only(), "fast_only"_a = false)
      .def_property_readonly("centers", [](const PySphereSet& s) { return Vec3Array(s.set->centers_rest); })
      .def_property_readonly("radii", [](const PySphereSet& s) { return CopyArray(s.set->radii_rest); })
      .def_property_readonly("radii_fast", [](const PySphereSet& s) { return CopyArray(s.set->radii_fast); })
      .def_property_readonly("sphere_part", [](const PySphereSet& s) { return CopyArray(s.set->sphere_part); })
      .def_property_readonly("sphere_joint", [](const PySphereSet& s) { return CopyArray(s.set->sphere_joint); })
      .def(
          "sphere_joints",
          [](const PySphereSet& s, size_t sphere) {
            const runtime::SphereSet& set = *s.set;
            if (sphere >= set.size() || set.influence_offsets.size() != set.size() + 1) {
              ThrowArgument("sphere " + std::to_string(sphere) + " out of range (" + std::to_string(set.size()) +
                            " spheres)");
            }
            const uint32_t a = set.influence_offsets[sphere], b = set.influence_offsets[sphere + 1];
            std::vector<uint16_t> joints(set.influence_joints.begin() + a, set.influence_joints.begin() + b);
            std::vector<float> weights(set.influence_weights.begin() + a, set.influence_weights.begin() + b);
            return py::make_tuple(CopyArray(joints), CopyArray(weights));
          },
          "sphere"_a)
      .def_property_readonly("part_names", [](const PySphereSet& s) { return Texts(PartNames(*s.set)); })
      .def_property_readonly("joint_names", [](const PySphereSet& s) { return Texts(s.set->joint_names); })
      .def_property_readonly("joint_parents", [](const PySphereSet& s) { return CopyArray(s.set->joint_parents); })
      .def_property_readonly("joint_rest_world",
                             [](const PySphereSet& s) { return MatrixArray(s.set->joint_rest_world); })
      .def_property_readonly(
          "excluded_pairs",
          [](const PySphereSet& s) {
            py::array_t<uint32_t> out({static_cast<py::ssize_t>(s.set->excluded_pairs.size()), py::ssize_t{2}});
            auto m2 = out.mutable_unchecked<2>();
            for (size_t k = 0; k < s.set->excluded_pairs.size(); ++k) {
              m2(static_cast<py::ssize_t>(k), 0) = s.set->excluded_pairs[k].i;
              m2(static_cast<py::ssize_t>(k), 1) = s.set->excluded_pairs[k].j;
            }
            return out;
          })
      .def_property_readonly("excluded_reasons",
                             [](const PySphereSet& s) {
                               std::vector<std::string> reasons;
                               for (const auto& e : s.set->excluded_pairs) reasons.emplace_back(ToString(e.reason));
                               return reasons;
                             })
      .def_property_readonly("contact_rules", [](const PySphereSet& s) { return ToString(s.set->contact_rules); })
      .def_property_readonly("contact_hops", [](const PySphereSet& s) { return s.set->contact_hops; })
      .def_property_readonly("rest_gap", [](const PySphereSet& s) { return s.set->rest_gap; })
      .def_property_readonly("vertex_count", [](const PySphereSet& s) { return s.set->source_vertex_count; })
      .def_property_readonly("triangle_count", [](const PySphereSet& s) { return s.set->source_triangle_count; })
      .def_property_readonly("has_mesh", [](const PySphereSet& s) { return s.set->has_mesh(); })
      .def_property_readonly("fast_only", [](const PySphereSet& s) { return s.set->fast_only; })
      .def_property_readonly("source_file", [](const PySphereSet& s) { return Text(s.set->source_file); })
      .def_property_readonly("loaded_from", [](const PySphereSet& s) { return Text(s.set->loaded_from); })
      .def_property_readonly("fit_report", [](const PySphereSet& s) { return py::dict(s.fit_report.attr("copy")()); })
      .def_property_readonly("triangles",
                             [](const PySphereSet& s) {
                               const auto& tv = s.set->triangle_vertices;
                               py::array_t<uint32_t> out({static_cast<py::ssize_t>(tv.size() / 3), py::ssize_t{3}});
                               if (!tv.empty())
                                 std::memcpy(out.mutable_data(), tv.data(), tv.size() * sizeof(uint32_t));
                               return out;
                             })
      .def_property_readonly("mesh", [](const PySphereSet& s) {
        const skinning::SkinnedMesh& mesh = s.set->mesh;
        std::vector<int32_t> joints;
        std::vector<Mat4f> inverse_binds;
        for (const auto& b : mesh.binds) {
          joints.push_back(b.joint);
          inverse_binds.push_back(b.inverse_bind);
        }
        py::dict d;
        d["positions_bind"] = Vec3Array(mesh.positions_bind);
        d["bind_joints"] = CopyArray(joints);
        d["inverse_binds"] = MatrixArray(inverse_binds);
        d["influence_offsets"] = CopyArray(mesh.influence_offsets);
        d["influence_binds"] = CopyArray(mesh.influence_binds);
        d["influence_weights"] = CopyArray(mesh.influence_weights);
        return d;
      });

  py::class_<PyAsset>(m, "Asset", "A sphere set made ready for the runtime: immutable, shared by its instances.")
      .def(py::init(&MakeAsset), "sphere_set"_a, py::kw_only(), "margin"_a = 0.0f,
           "touch_tolerance"_a = tool::kDefaultTouchTolerance)
      .def(
          "instance",
          [](const PyAsset& a, const std::optional<std::vector<std::string>>& joint_names) {
            return std::make_unique<PyInstance>(a, joint_names);
          },
          "joint_names"_a = py::none())
      .def(
          "check",
          [](const PyAsset& a, const std::vector<std::string>& joint_names, size_t vertex_count) {
            if (auto e = a.asset->Matches(joint_names, vertex_count)) Throw(*e);
          },
          "joint_names"_a, "vertex_count"_a)
      .def("fix_pose", &FixPose, "locals"_a, py::kw_only(), "max_depth"_a = 0.0f)
      .def_property_readonly("sphere_set", &SetOf)
      .def_property_readonly("part_names", [](const PyAsset& a) { return Texts(PartNames(a.asset->sphere_set())); })
      .def_property_readonly("joint_names", [](const PyAsset& a) { return Texts(a.asset->sphere_set().joint_names); })
      .def_property_readonly("joints_read",
                             [](const PyAsset& a) {
                               const std::vector<bool> read = runtime::JointsReadPerFrame(a.asset->sphere_set());
                               py::array_t<bool> out(static_cast<py::ssize_t>(read.size()));
                               for (size_t k = 0; k < read.size(); ++k) out.mutable_data()[k] = read[k];
                               return out;
                             })
      .def_property_readonly("sphere_count", [](const PyAsset& a) { return a.asset->size(); })
      .def_property_readonly("vertex_count", [](const PyAsset& a) { return a.asset->source_vertex_count(); })
      .def_property_readonly("has_contacts", [](const PyAsset& a) { return a.asset->narrow_phase() != nullptr; })
      .def_property_readonly(
          "margin",
          [](const PyAsset& a) { return a.asset->narrow_phase() ? a.asset->narrow_phase()->settings().margin : 0.0f; })
      .def_property_readonly("touch_tolerance", [](const PyAsset& a) {
        return a.asset->narrow_phase() ? a.asset->narrow_phase()->touch_tolerance() : 0.0f;
      });

  py::class_<PyInstance>(m, "Instance", "One character's per-frame state; one thread at a time.")
      .def(py::init<const PyAsset&, const std::optional<std::vector<std::string>>&>(), "asset"_a,
           "joint_names"_a = py::none())
      .def("update_fast", &PyInstance::UpdateFast, "world"_a)
      .def("update_exact", &PyInstance::UpdateExact, "positions"_a, "world"_a = py::none())
      .def("sphere_pairs", &PyInstance::SpherePairs)
      .def(
          "contacts",
          [](PyInstance& self, const py::handle& positions) {
            py::tuple t = self.Contacts(positions);
            return g_contacts_type(t[0], t[1]);
          },
          "positions"_a = py::none())
      .def("_cpp_frame_loop", &PyInstance::CppFrameLoop, "worlds"_a, "contacts"_a = true, "repeats"_a = 1)
      .def_property_readonly("spheres", &PyInstance::Spheres)
      .def_property_readonly("asset", &PyInstance::asset)
      .def_property_readonly("joint_count", &PyInstance::joint_count)
      .def_property_readonly("extra_joints", [](const PyInstance& i) { return Texts(i.mapping().extra_engine_joints); })
      .def_property_readonly("unmapped_joints",
                             [](const PyInstance& i) { return Texts(i.mapping().unmapped_set_joints); });

  const tool::FitOptions d;  // the tool's defaults
  m.def(
      "fit",
      [](const std::optional<PathText>& path, const std::string& parts, int rays, int per_level,
         const std::string& method, float overlap, float step, int hops, int refine, bool tighten, float split_gain,
         int split_rounds, float target_standoff, int max_spheres, float rest_gap, float piece_edge,
         bool group_blends) {
        NoNul(parts, "parts");
        tool::FitOptions o;  // what the tool's options of the same names set
        o.parts_file = parts;
        o.settings.rays = rays;
        o.settings.per_level = per_level;
        o.method = method;
        o.settings.overlap = overlap;
        o.settings.step = step;
        o.settings.contact_hops = hops;
        o.settings.refine_iterations = refine;
        o.no_tighten = !tighten;
        o.settings.split_gain = split_gain;
        o.settings.split_rounds = split_rounds;
        o.settings.target_standoff = target_standoff;
        o.settings.max_spheres = max_spheres;
        o.settings.rest_gap = rest_gap;
        o.settings.piece_edge = piece_edge;
        o.no_group_blends = !group_blends;
        return Fit(path, o);
      },
      "path"_a = py::none(), py::kw_only(), "parts"_a = d.parts_file, "rays"_a = d.settings.rays,
      "per_level"_a = d.settings.per_level, "method"_a = d.method, "overlap"_a = d.settings.overlap,
      "step"_a = d.settings.step, "hops"_a = d.settings.contact_hops, "refine"_a = d.settings.refine_iterations,
      "tighten"_a = !d.no_tighten, "split_gain"_a = d.settings.split_gain, "split_rounds"_a = d.settings.split_rounds,
      "target_standoff"_a = d.settings.target_standoff, "max_spheres"_a = d.settings.max_spheres,
      "rest_gap"_a = d.settings.rest_gap, "piece_edge"_a = d.settings.piece_edge,
      "group_blends"_a = !d.no_group_blends);
  m.def("load", &Load, "path"_a);
  m.def(
      "clip_names", [](const PathText& path) { return Texts(ClipNames(path)); }, "path"_a);
  m.def(
      "play",
      [](const std::optional<PathText>& character, const std::optional<PathText>& clip_file,
         const std::variant<int64_t, std::string>& clip, float fps, const std::string& mode, int64_t frames,
         const std::optional<PathText>& spheres, float margin, float touch_tolerance, const std::string& joint_map,
         const std::string& source_rest, const std::string& retarget) {
        PlayArgs a;
        if (clip_file) a.clip_files.push_back(clip_file->value);
        if (const int64_t* index = std::get_if<int64_t>(&clip)) {
          if (*index < 0) ThrowArgument("clip: " + std::to_string(*index) + " (an index counts from 0)");
          a.clip = std::to_string(*index);
        } else {
          a.clip = std::get<std::string>(clip);
        }
        if (frames < 0 || frames > kMaxPlayFrames) {
          ThrowArgument("frames: " + std::to_string(frames) + " (0: the whole clip; at most " +
                        std::to_string(kMaxPlayFrames) + ")");
        }
        NoNul(joint_map, "joint_map");
        NoNul(source_rest, "source_rest");
        a.fps = fps;
        a.mode = mode;
        a.frames = static_cast<int>(frames);
        if (spheres) a.spheres = spheres->value;
        a.margin = margin;
        a.touch_tolerance = touch_tolerance;
        a.joint_map = joint_map;
        a.source_rest = source_rest;
        a.retarget = retarget;
        return Play(character ? std::optional<std::string>(character->value) : std::nullopt, a);
      },
      "character"_a = py::none(), "clip_file"_a = py::none(), py::kw_only(), "clip"_a = int64_t{0}, "fps"_a = 30.0f,
      "mode"_a = "exact", "frames"_a = 0, "spheres"_a = py::none(), "margin"_a = 0.0f,
      "touch_tolerance"_a = tool::kDefaultTouchTolerance, "joint_map"_a = "", "source_rest"_a = "",
      "retarget"_a = "auto");
  m.def(
      "retarget",
      [](const PathText& character, const std::vector<PathText>& clip_files, const PathText& output,
         const std::string& clip, float fps, const std::string& joint_map, const std::string& source_rest,
         const std::string& retarget, const std::string& rest_directions) {
        std::vector<std::string> files;
        for (const PathText& f : clip_files) files.push_back(f.value);
        NoNul(joint_map, "joint_map");
        NoNul(source_rest, "source_rest");
        return Retarget(character.value, ClipFiles(files, joint_map, source_rest, retarget, rest_directions),
                        output.value, clip, fps);
      },
      "character"_a, "clip_files"_a, "output"_a, py::kw_only(), "clip"_a = "all", "fps"_a = 30.0f, "joint_map"_a = "",
      "source_rest"_a = "", "retarget"_a = "auto", "rest_directions"_a = "keep");
  m.def(
      "check",
      [](const PathText& character, const std::vector<PathText>& clip_files, const std::string& clip, float max_depth,
         float touch_tolerance, const std::optional<PathText>& spheres, float fps, const std::string& mode, int jobs,
         const std::string& joint_map, const std::string& source_rest, const std::string& retarget,
         bool compare_source) {
        std::vector<std::string> files;
        for (const PathText& f : clip_files) files.push_back(f.value);
        NoNul(joint_map, "joint_map");
        NoNul(source_rest, "source_rest");
        tool::CheckArgs a;
        a.input = character.value;
        a.clip_files = ClipFiles(files, joint_map, source_rest, retarget, "keep");
        a.clip = clip;
        a.max_depth = max_depth;
        a.touch_tolerance = touch_tolerance;
        a.spheres = spheres ? spheres->value : "";
        a.fps = fps;
        a.mode = mode;
        a.jobs = jobs;
        a.compare_source = compare_source;
        return Check(std::move(a));
      },
      "character"_a, "clip_files"_a = std::vector<PathText>{}, py::kw_only(), "clip"_a = "all",
      "max_depth"_a = tool::kDefaultMaxDepth, "touch_tolerance"_a = tool::kDefaultTouchTolerance,
      "spheres"_a = py::none(), "fps"_a = 30.0f, "mode"_a = "exact", "jobs"_a = 0, "joint_map"_a = "",
      "source_rest"_a = "", "retarget"_a = "auto", "compare_source"_a = false);
  m.def(
      "fix",
      [](const PathText& character, const PathText& output, const std::vector<PathText>& clip_files,
         const std::string& clip, float max_depth, const std::vector<std::string>& allow,
         const std::optional<PathText>& spheres, float fps, float ease, float max_rotation, float max_jerk_ratio,
         int jobs, const std::string& joint_map, const std::string& source_rest, const std::string& retarget) {
        std::vector<std::string> files;
        for (const PathText& f : clip_files) files.push_back(f.value);
        NoNul(joint_map, "joint_map");
        NoNul(source_rest, "source_rest");
        FixArgs a{clip, allow,     max_depth,    spheres ? std::optional<std::string>(spheres->value) : std::nullopt,
                  fps,  ease,      max_rotation, max_jerk_ratio,
                  jobs, joint_map, source_rest,  retarget};
        return Fix(character.value, files, output.value, a);
      },
      "character"_a, "output"_a, "clip_files"_a = std::vector<PathText>{}, py::kw_only(), "clip"_a = "all",
      "max_depth"_a = tool::kDefaultTouchTolerance, "allow"_a = std::vector<std::string>{}, "spheres"_a = py::none(),
      "fps"_a = 30.0f, "ease"_a = 0.2f, "max_rotation"_a = 60.0f, "max_jerk_ratio"_a = 1.5f, "jobs"_a = 0,
      "joint_map"_a = "", "source_rest"_a = "", "retarget"_a = "auto");
  m.def(
      "colliders",
      [](const PathText& character, const std::vector<PathText>& clip_files, int budget, const std::string& shapes,
         const std::string& format, const std::optional<PathText>& output, const std::optional<PathText>& report,
         const std::string& clip, float fps, float tolerance, int fit_poses, bool compare, const std::string& joint_map,
         const std::string& source_rest, const std::string& retarget) {
        tool::CollidersArgs a;
        a.input = character.value;
        std::vector<std::string> files;
        for (const PathText& f : clip_files) files.push_back(f.value);
        NoNul(joint_map, "joint_map");
        NoNul(source_rest, "source_rest");
        a.clip_files = ClipFiles(files, joint_map, source_rest, retarget, "keep");
        a.budget = budget;
        a.shapes = shapes;
        a.format = format;
        a.output = output ? output->value : "";
        a.report = report ? report->value : "";
        a.clip = clip;
        a.fps = fps;
        a.tolerance = tolerance;
        a.fit_poses = fit_poses;
        a.compare = compare;
        return Colliders(std::move(a));
      },
      "character"_a, "clip_files"_a = std::vector<PathText>{}, py::kw_only(), "budget"_a = 32, "shapes"_a = "auto",
      "format"_a = "json", "output"_a = py::none(), "report"_a = py::none(), "clip"_a = "all", "fps"_a = 30.0f,
      "tolerance"_a = 0.01f, "fit_poses"_a = 64, "compare"_a = false, "joint_map"_a = "", "source_rest"_a = "",
      "retarget"_a = "auto");
}
