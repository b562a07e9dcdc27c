// `icube video` : video files in and out of a clip.
//
//   icube video frames VIDEO -o OUTDIR [--max N]
//
// Decodes a video (mp4/H.264 or anything libavformat reads: InfiniCube's
// generated `video_480p_front.mp4`, or the engine's own buffer mp4s) into
// OUTDIR/NNNNNN.png, RGB8, numbered 0 ... N-1 like the clip's buffers, so
// frame k of a video model's output sits beside buffer frame k. OUTDIR is
// built in a staging folder and renamed into place.
// Engine: engine/video/mp4_reader.h.
#include "cli_common.h"
#include "command_registry.h"
#include "progress.h"
#include "staging_dir.h"

#include "scene/atomic_file.h"
#include "scene/png_write.h"
#include "video/mp4_reader.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

namespace icube::tools {
namespace {

namespace fs = std::filesystem;

struct VideoFramesArgs {
  std::string input, output;
  size_t max_frames = 0;
};

void cmd_video_frames(const VideoFramesArgs& a) {
  run_command([&](scene::Diagnostics&) {
    const video::DecodedVideo v = video::read_video(a.input, a.max_frames);
    const fs::path out(a.output);
    if (fs::exists(out) && !fs::is_empty(out))
      throw std::invalid_argument(a.output + ": exists and is not empty; choose a new folder");
    StagingDir staging(out.parent_path().empty() ? fs::path(".") : out.parent_path(), out.filename().string());
    ProgressBar bar("video", "frames");
    for (size_t f = 0; f < v.frames.size(); ++f) {
      char name[32];
      std::snprintf(name, sizeof name, "%06zu.png", f);
      scene::write_file_atomic((staging.path / name).string(),
                               scene::encode_png(v.frames[f].data(), static_cast<int>(v.width),
                                                 static_cast<int>(v.height), 3));
      bar.update(f + 1, v.frames.size());
    }
    if (fs::exists(out)) fs::remove(out);  // an empty folder
    fs::rename(staging.path, out);
    staging.keep = true;
    std::printf("video: %zu frames %ux%u at %.3g fps -> %s/000000.png ...\n", v.frames.size(), v.width, v.height, v.fps,
                a.output.c_str());
  });
}

void add_video_commands(CLI::App& app) {
  CLI::App& group = subcommand_group(app, "video", "Video files: decode a video model's output into frames");
  auto a = std::make_shared<VideoFramesArgs>();
  CLI::App* cmd = group.add_subcommand("frames", "Decode a video (e.g. InfiniCube's video_480p_front.mp4) into PNG frames");
  cmd->add_option("video", a->input, "Video file (.mp4, H.264; anything libavformat reads)")->required()->type_name("VIDEO");
  cmd->add_option("-o,--output", a->output, "Output folder: NNNNNN.png, numbered 0..N-1 like the clip's buffers")
      ->required()
      ->type_name("OUTDIR");
  cmd->add_option("--max", a->max_frames, "At most this many frames (0 = all)")->type_name("N");
  cmd->footer("The frames are RGB8 after libswscale's YUV->RGB (BT.601); an odd-sized video written by the engine "
              "carries one padding column/row.");
  cmd->callback([a] { cmd_video_frames(*a); });
}

const CommandRegistrar kVideoRegistrar(add_video_commands, 48);

}  // namespace
}  // namespace icube::tools
