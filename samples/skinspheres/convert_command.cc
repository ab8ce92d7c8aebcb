// skinspheres convert IN OUT [--fast-only]: a sphere set from one format to the other (JSON .json,
// binary .ssb; the input's format is read from its content, the output's from its extension), and
// the same choice for `fit -o`.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "skinspheres/runtime/format/sphere_set_io.h"

namespace skinspheres::tool {

std::optional<std::string> SaveSetFile(const runtime::SphereSet& set, const std::string& path, bool fast_only) {
  const auto format = runtime::SphereSetFormatForPath(path);
  if (!format) return path + ": unknown sphere-set extension (use .json for JSON or .ssb for binary)";
  if (fast_only && *format == runtime::SphereSetFileFormat::kJson) {
    return path + ": --fast-only needs a binary (.ssb) output; JSON always holds the whole set";
  }
  const runtime::SphereSetFileFormat chosen = fast_only ? runtime::SphereSetFileFormat::kBinaryFastOnly : *format;
  if (auto err = runtime::SaveSphereSet(set, path, chosen)) return err->message;
  return std::nullopt;
}

namespace {

struct ConvertArgs {
  std::string input, output;
  bool fast_only = false;
};

int RunConvert(const ConvertArgs& a) {
  auto set = runtime::LoadSphereSet(a.input);
  if (!set.ok()) return Fail(set.error().message);
  if (auto why = SaveSetFile(*set, a.output, a.fast_only)) return Fail(*why);
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(a.output, ec);
  const bool binary = runtime::SphereSetFormatForPath(a.output) == runtime::SphereSetFileFormat::kBinary;
  std::printf("wrote %s: %s%s, %zu spheres, %llu bytes (from %s)\n", a.output.c_str(), binary ? "binary" : "JSON",
              a.fast_only || set->fast_only ? " fast-only" : "", set->size(), static_cast<unsigned long long>(bytes),
              a.input.c_str());
  return 0;
}

}  // namespace

void AddConvertCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<ConvertArgs>();
  CLI::App* cmd =
      app.add_subcommand("convert", "convert a sphere set between JSON (.json) and binary (.ssb), losslessly");
  cmd->add_option("input", a->input, "sphere set to read (JSON or binary, told apart by content)")->required();
  cmd->add_option("output", a->output, "sphere set to write: .json or .ssb")->required();
  cmd->add_flag("--fast-only", a->fast_only,
                "binary output without what only exact mode and triangle tests read (smaller; exact mode refused)");
  cmd->callback([a, exit_code] { *exit_code = RunConvert(*a); });
}

}  // namespace skinspheres::tool
