#include "command_registry.h"

#include <algorithm>
#include <utility>
#include <vector>

namespace icube::tools {

namespace {
std::vector<std::pair<int, CommandAdder>>& registry() {
  static std::vector<std::pair<int, CommandAdder>> r;  // function-local: safe during static initialisation
  return r;
}
}  // namespace

CommandRegistrar::CommandRegistrar(CommandAdder adder, int order) { registry().emplace_back(order, adder); }

void register_all_commands(CLI::App& app) {
  auto entries = registry();
  std::stable_sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [order, adder] : entries) adder(app);
}

CLI::App& subcommand_group(CLI::App& app, const std::string& name, const std::string& description) {
  for (CLI::App* sub : app.get_subcommands({}))
    if (sub->get_name() == name) return *sub;
  CLI::App* sub = app.add_subcommand(name, description);
  sub->require_subcommand(1);
  return *sub;
}

}  // namespace icube::tools
