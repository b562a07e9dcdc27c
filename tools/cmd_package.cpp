// `icube package verify PACKAGE...`: checks packages written by `icube
// generate` against their manifests (engine/scene/package_check.h): every
// listed file present with its SHA-256, nothing unlisted. One line per
// package; exit status 1 when any is partial or corrupt.
#include "cli_common.h"
#include "command_registry.h"

#include "scene/package_check.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace icube::tools {
namespace {

struct PackageVerifyArgs {
  std::vector<std::string> packages;
  bool quick = false;
};

void cmd_package_verify(const PackageVerifyArgs& a) {
  run_command([&](scene::Diagnostics&) {
    size_t bad = 0;
    for (const std::string& p : a.packages) {
      const scene::PackageCheck c = scene::check_package(p, !a.quick);
      if (c.complete)
        std::printf("%s: complete (%zu files%s)\n", p.c_str(), c.files, a.quick ? ", present" : " verified");
      else
        std::printf("%s: INCOMPLETE: %s\n", p.c_str(), c.problem.c_str());
      bad += c.complete ? 0 : 1;
    }
    if (bad) throw std::runtime_error(std::to_string(bad) + " of " + std::to_string(a.packages.size()) +
                                      " package(s) partial or corrupt");
  });
}

void add_package_commands(CLI::App& app) {
  CLI::App* pkg = app.add_subcommand("package", "Packages written by `icube generate`");
  pkg->require_subcommand(1);
  auto a = std::make_shared<PackageVerifyArgs>();
  CLI::App* verify = pkg->add_subcommand(
      "verify", "Check packages against their manifests: every file present with its SHA-256, nothing unlisted");
  verify->add_option("packages", a->packages, "Package folders")->required()->type_name("PACKAGE...");
  verify->add_flag("--quick", a->quick, "Check presence only, not the hashes");
  verify->callback([a] { cmd_package_verify(*a); });
}

const CommandRegistrar kPackageRegistrar(add_package_commands, 6);

}  // namespace
}  // namespace icube::tools
