// `icube splat`: 3D Gaussian splatting scenes (engine/splat/).
//
//   icube splat render SCENE.ply --camera fx,fy,cx,cy,w,h --trajectory POSES.npy
//                      [--antialiased] [--near Z] [--far Z] [--background r,g,b]
//                      [--integer-pixels] [--depth] -o OUTDIR
//   icube splat info FILE.ply
//
// POSES: .npy [N,4,4] (or icube-trajectory JSON) of OpenCV camera-to-world
// poses in the scene's frame. Output: OUTDIR/NNNNNN.png (RGB, background
// composited, sRGB values as stored in the SH: clamped to [0, 1] and ×255)
// and with --depth OUTDIR/NNNNNN_depth.npy (float32 [H, W, 2]: expected and
// median depth in metres, 0 where nothing was hit).
#include "cli_common.h"
#include "command_registry.h"
#include "progress.h"

#include "gpu/context.h"
#include "render/buffers/trajectory.h"
#include "scene/png_write.h"
#include "splat/gaussians.h"
#include "splat/rasterizer_gpu.h"
#include "world/npy.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace icube::tools {

namespace {

namespace fs = std::filesystem;

struct SplatRenderArgs {
  std::string scene, camera, trajectory, background = "0,0,0", output;
  double near_z = 0.01, far_z = 1e10;
  bool antialiased = false, integer_pixels = false, depth = false;
};

glm::vec3 parse_rgb(const std::string& s) {
  glm::vec3 c(0.0f);
  std::stringstream in(s);
  std::string tok;
  int k = 0;
  while (std::getline(in, tok, ',')) {
    if (k >= 3) throw std::invalid_argument("--background: expected r,g,b");
    size_t used = 0;
    c[k++] = std::stof(tok, &used);
    if (used != tok.size()) throw std::invalid_argument("--background: '" + tok + "' is not a number");
  }
  if (k != 3) throw std::invalid_argument("--background: expected r,g,b");
  return c;
}

void cmd_render(const SplatRenderArgs& a) {
  run_command([&](scene::Diagnostics&) {
    const auto t0 = std::chrono::steady_clock::now();
    const splat::GaussianCloud cloud = splat::read_gaussians_ply(a.scene);
    render::TrajectoryFile tf = render::load_trajectory(a.trajectory, 0);
    if (tf.passes.size() != 1) throw std::invalid_argument(a.trajectory + ": expected one pass of poses [N,4,4]");
    render::PinholeIntrinsics K;
    if (!a.camera.empty()) K = render::parse_camera(a.camera);
    else if (tf.camera) K = *tf.camera;
    else throw std::invalid_argument("give --camera fx,fy,cx,cy,w,h");
    splat::SplatOptions opts;
    opts.near_z = a.near_z;
    opts.far_z = a.far_z;
    opts.antialiased = a.antialiased;
    opts.pixels = a.integer_pixels ? render::PixelConvention::Integer : render::PixelConvention::Centre;
    opts.background = parse_rgb(a.background);
    fs::create_directories(a.output);
    gpu::Context ctx(gpu::ContextOptions::from_env());
    splat::SplatRendererGpu renderer(ctx);
    const splat::GpuGaussians g = renderer.upload(cloud);
    const auto& traj = tf.passes[0];
    ProgressBar bar("splat render", "frames");
    double render_ms = 0.0;
    std::vector<uint8_t> rgb(size_t{K.width} * K.height * 3);
    for (size_t i = 0; i < traj.size(); ++i) {
      render::Camera cam{K, traj.c2w[i]};
      splat::SplatTimings t;
      const splat::SplatImage img = renderer.render(g, cam, opts, &t);
      render_ms += t.wall_ms;
      for (size_t p = 0; p < size_t{K.width} * K.height; ++p)
        for (int c = 0; c < 3; ++c)
          rgb[3 * p + c] = static_cast<uint8_t>(std::lround(std::clamp(img.rgba[4 * p + c], 0.0f, 1.0f) * 255.0f));
      char name[32];
      std::snprintf(name, sizeof name, "%06d", traj.frame_index.empty() ? static_cast<int>(i) : traj.frame_index[i]);
      scene::write_png((fs::path(a.output) / (std::string(name) + ".png")).string(), rgb.data(),
                       static_cast<int>(K.width), static_cast<int>(K.height), 3);
      if (a.depth)
        world::write_npy((fs::path(a.output) / (std::string(name) + "_depth.npy")).string(),
                         world::NpyArray::make<float>({K.height, K.width, 2}, img.depth));
      bar.update(i + 1, traj.size());
    }
    const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("splat render: %zu Gaussians (SH%u), %zu frames %ux%u, %.1f ms/frame rendering, %.2f s total -> %s\n",
                cloud.size(), cloud.sh_degree, traj.size(), K.width, K.height,
                traj.size() ? render_ms / static_cast<double>(traj.size()) : 0.0, total_s, a.output.c_str());
  });
}

void cmd_info(const std::string& path) {
  run_command([&](scene::Diagnostics&) {
    const splat::GaussianCloud c = splat::read_gaussians_ply(path);
    const splat::CloudSummary s = splat::summarize(c);
    std::printf("%s: %zu Gaussians, SH degree %u (%u floats/Gaussian on the GPU incl. padding)\n", path.c_str(), s.count,
                s.sh_degree, 12u + (3u * c.sh_coeffs() + 3u) / 4u * 4u);
    std::printf("  bounds   [%.3f, %.3f] x [%.3f, %.3f] x [%.3f, %.3f] m, centroid (%.3f, %.3f, %.3f)\n", s.min.x,
                s.max.x, s.min.y, s.max.y, s.min.z, s.max.z, s.centroid.x, s.centroid.y, s.centroid.z);
    std::printf("  opacity  min %.4f mean %.4f max %.4f (after sigmoid)\n", s.opacity_min, s.opacity_mean,
                s.opacity_max);
    std::printf("  scale    min %.3g median %.3g max %.3g m (after exp, all axes)\n", s.scale_min, s.scale_median,
                s.scale_max);
  });
}

void add_splat_commands(CLI::App& app) {
  CLI::App& group = subcommand_group(app, "splat", "3D Gaussian splatting scenes: render and inspect .ply files");
  auto a = std::make_shared<SplatRenderArgs>();
  CLI::App* r = group.add_subcommand("render", "Render a 3DGS .ply along camera poses (GPU tile rasterizer)");
  r->add_option("scene", a->scene, "3DGS .ply (binary little-endian or ascii, SH degree 0-3)")->required()->type_name("SCENE.ply");
  r->add_option("--camera", a->camera, "Pinhole intrinsics in pixels")->type_name("fx,fy,cx,cy,w,h");
  r->add_option("--trajectory", a->trajectory, "Poses: .npy [N,4,4] OpenCV camera-to-world (or icube-trajectory JSON)")
      ->required()
      ->type_name("POSES.npy");
  r->add_flag("--antialiased", a->antialiased, "Mip-Splatting 2-D filter compensation (for assets trained with it)");
  r->add_option("--near", a->near_z, "Near plane: view z <= Z is culled")->type_name("Z")->capture_default_str();
  r->add_option("--far", a->far_z, "Far plane: view z > Z is culled")->type_name("Z")->capture_default_str();
  r->add_option("--background", a->background, "Background colour")->type_name("r,g,b")->capture_default_str();
  r->add_flag("--integer-pixels", a->integer_pixels, "Sample pixel u at u (Inria) instead of u + 0.5 (gsplat)");
  r->add_flag("--depth", a->depth, "Also write NNNNNN_depth.npy (float32 [H,W,2]: expected, median depth)");
  r->add_option("-o,--output", a->output, "Output folder")->required()->type_name("OUTDIR");
  r->callback([a] { cmd_render(*a); });
  auto path = std::make_shared<std::string>();
  CLI::App* i = group.add_subcommand("info", "Summarise a 3DGS .ply (count, SH degree, bounds, opacity and scale)");
  i->add_option("file", *path, "3DGS .ply")->required()->type_name("FILE");
  i->callback([path] { cmd_info(*path); });
}

const CommandRegistrar kRegistrar(add_splat_commands, 47);

}  // namespace

}  // namespace icube::tools
