// skinspheres: the command-line tool.
//   skinspheres fit INPUT -o OUT.json [...]      fit a sphere set (see fit_command.cc); .ssb: binary
//   skinspheres convert IN OUT [--fast-only]     sphere set JSON <-> binary (convert_command.cc)
//   skinspheres play INPUT [...]                 play a clip: sample, skin, refit, query (play_command.cc)
//   skinspheres check INPUT --clips FILE... [...] check an animation library for penetration (check_command.cc)
//   skinspheres retarget INPUT --clips FILE... -o OUT.glb  the clips retargeted, written as glTF (retarget_command.cc)
//   skinspheres demo                             fit and play the built-in character
//   skinspheres export-builtin OUT.glb           write the built-in character as glTF
//   skinspheres --version                        "skinspheres <version>" (the project's VERSION)
#include <CLI/CLI.hpp>
#include <exception>
#include <new>
#include <string>

#include "colliders.h"
#include "fix.h"
#include "playback.h"
#include "skinspheres/version.h"

int main(int argc, char** argv) {
  CLI::App app{"skinspheres: sphere approximation and self-collision for skinned characters"};
  app.require_subcommand(0, 1);  // none: one line pointing at --help (below), not CLI11's message
  app.set_version_flag("--version", std::string("skinspheres ") + SKINSPHERES_VERSION_STRING,
                       "print the version and exit");
  int exit_code = 0;
  skinspheres::tool::AddFitCommand(app, &exit_code);
  skinspheres::tool::AddPlayCommand(app, &exit_code);
  skinspheres::tool::AddCheckCommand(app, &exit_code);
  skinspheres::tool::AddRetargetCommand(app, &exit_code);
  skinspheres::tool::AddFixCommand(app, &exit_code);
  skinspheres::tool::AddCollidersCommand(app, &exit_code);
  skinspheres::tool::AddDemoCommand(app, &exit_code);
  skinspheres::tool::AddExportBuiltinCommand(app, &exit_code);
  skinspheres::tool::AddConvertCommand(app, &exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version: CLI11 prints them (exit 0). Every argument error is one line (CLI11's
    // own exit() adds a second, "Run with --help ..."), exit 2.
    if (e.get_exit_code() == 0) return app.exit(e);
    return skinspheres::tool::Fail(e.what());
  } catch (const std::bad_alloc&) {
    // Last line of defence: one line that says what happened ("std::bad_alloc" did not), never an abort.
    return skinspheres::tool::Fail("out of memory (the input or the options ask for more than this machine gives)");
  } catch (const std::exception& e) {
    // Last line of defence (a library throwing): one line, never an abort.
    return skinspheres::tool::Fail(std::string("internal error: ") + e.what());
  }
  if (app.get_subcommands().empty()) return skinspheres::tool::Fail("no command given; try `skinspheres --help`");
  return exit_code;
}
