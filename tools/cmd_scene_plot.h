// `icube scene plot` and `icube scene route`: registered under the `scene`
// subcommand group by add_scene_commands() (tools/cmd_scene.cpp). Defined in
// tools/cmd_scene_plot.cpp.
#pragma once

namespace CLI {
class App;
}

namespace icube::tools {

// Adds the `plot` and `route` subcommands to `scene_cmd` (the `scene` group).
void add_scene_plot_commands(CLI::App& scene_cmd);

}  // namespace icube::tools
