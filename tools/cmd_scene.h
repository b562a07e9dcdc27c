// `icube scene ...`: reading, inspecting and converting driving scenes.
//
//   icube scene info FILE [--record SEL]                         counts, extents, time span, what is missing
//   icube scene convert FILE -o scene.json [--record SEL] [--step M]   any reader -> icube scene JSON
//   icube scene plot / route                                     tools/cmd_scene_plot.cpp
//
// FILE is an icube scene JSON, a Waymo Open Motion Dataset Scenario TFRecord
// or an OpenDRIVE map, recognised by content. Errors print one line,
// "icube: error: <file>: <where>: <what>", and exit with status 1; reader
// warnings go to stderr as "icube: warning: ...".
#pragma once

namespace CLI {
class App;
}

namespace icube::tools {

// Registers the `scene` subcommand group (info, convert, and the plot/route
// hook add_scene_plot_commands) on the top-level app. Commands run from their
// CLI11 callbacks during app.parse(); a failing command throws
// CLI::RuntimeError(1), which app.exit() turns into exit status 1 silently.
void add_scene_commands(CLI::App& app);

}  // namespace icube::tools
