// Self-registering subcommand groups for the icube CLI.
//
// A tools/cmd_<topic>.cpp file registers its subcommands with
//   static const icube::tools::CommandRegistrar kMyTopicRegistrar(add_my_commands, /*order=*/40);
// (a name of its own: the CLI builds as one unity translation unit, CMake UNITY_BUILD)
// and icube_main.cpp calls register_all_commands(app) once, so adding a
// command group needs no edit elsewhere. `order` fixes the --help order.
// subcommand_group(app, "world", "...") returns the shared parent of a group
// that several files add to (created on first use).
#pragma once

#include <CLI/CLI.hpp>

#include <string>

namespace icube::tools {

using CommandAdder = void (*)(CLI::App& app);

struct CommandRegistrar {
  CommandRegistrar(CommandAdder adder, int order);
};

void register_all_commands(CLI::App& app);

CLI::App& subcommand_group(CLI::App& app, const std::string& name, const std::string& description);

}  // namespace icube::tools
