// `icube splat`: 3D Gaussian splatting scenes (engine/splat/).
//
//   icube splat render SCENE.ply|SCENE.splat|scene.json --camera fx,fy,cx,cy,w,h
//                      --trajectory POSES.npy [--antialiased] [--near Z] [--far Z]
//                      [--background r,g,b] [--sky background|gradient|FILE.png] [--integer-pixels] [--depth] -o OUTDIR
//   icube splat info FILE.ply|FILE.splat|scene.json
//   icube splat convert IN.ply|IN.splat OUT.ply|OUT.splat
//
// POSES: .npy [N,4,4] (or icube-trajectory JSON) of OpenCV camera-to-world
// poses in the scene's frame. Output: OUTDIR/NNNNNN.png (RGB, background
// composited, sRGB values as stored in the SH: clamped to [0, 1] and ×255)
// and with --depth OUTDIR/NNNNNN_depth.npy (float32 [H, W, 2]: expected and
// median depth in metres, 0 where nothing was hit). Every file is written
// atomically (temporary name, then rename).
// A scene .json (engine/splat/splat_scene.h, docs/splat-scene.md) has dynamic
// objects: pose i renders scene frame i (or the trajectory JSON's
// time_indices[i]); poses past the scene's last frame see the last frame, as
// the guidance buffers do (render/buffers/trajectory.h), with a note on stderr.
#include "cli_common.h"
#include "command_registry.h"
#include "progress.h"

#include "gpu/context.h"
#include "render/buffers/trajectory.h"
#include "scene/png_write.h"
#include "splat/splat_rgba8.h"
#include "splat/gaussians.h"
#include "splat/rasterizer_gpu.h"
#include "splat/splat_format.h"
#include "splat/sky.h"
#include "splat/splat_scene.h"
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
  std::string scene, camera, trajectory, background = "0,0,0", sky = "background", output;
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
  run_command([&](scene::Diagnostics& diag) {
    const auto t0 = std::chrono::steady_clock::now();
    const splat::SplatScene scn = splat::read_splat_scene(a.scene);
    render::TrajectoryFile tf = render::load_trajectory(a.trajectory, scn.frames());
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
    opts.sky = splat::parse_sky(a.sky);
    opts.depth = a.depth;  // without --depth the blend leaves the depth outputs out
    const auto& traj = tf.passes[0];
    if (scn.has_objects() && traj.size() > scn.frames() && scn.frames() > 0)
      diag.warn(a.trajectory, "",
                std::to_string(traj.size()) + " poses but the scene has " + std::to_string(scn.frames()) +
                    " frames: poses from " + std::to_string(scn.frames()) + " on see the last frame");
    print_warnings(diag);
    diag.warnings.clear();
    fs::create_directories(a.output);
    gpu::Context ctx(gpu::ContextOptions::from_env());
    splat::SplatRendererGpu renderer(ctx);
    // A static scene is uploaded once; with objects, each distinct frame is composed and uploaded.
    auto frame_of = [&](size_t i) -> size_t {
      if (!scn.has_objects() || traj.time_index.empty() || traj.time_index[i] < 0) return 0;
      return static_cast<size_t>(traj.time_index[i]);
    };
    std::unique_ptr<splat::GpuGaussians> g;
    size_t uploaded_frame = 0, max_count = 0;
    uint32_t sh_degree = scn.static_set.sh_degree;
    ProgressBar bar("splat render", "frames");
    double render_ms = 0.0;
    std::vector<uint8_t> rgb(size_t{K.width} * K.height * 3);
    for (size_t i = 0; i < traj.size(); ++i) {
      const size_t frame = frame_of(i);
      if (!g || frame != uploaded_frame) {
        g.reset();
        const splat::GaussianCloud cloud = scn.has_objects() ? splat::compose_frame(scn, frame) : scn.static_set;
        g = std::make_unique<splat::GpuGaussians>(renderer.upload(cloud));
        uploaded_frame = frame;
        max_count = std::max(max_count, cloud.size());
        sh_degree = std::max(sh_degree, cloud.sh_degree);
      }
      render::Camera cam{K, traj.c2w[i]};
      splat::SplatTimings t;
      const splat::SplatImage img = renderer.render(*g, cam, opts, &t);
      render_ms += t.wall_ms;
      for (size_t p = 0; p < size_t{K.width} * K.height; ++p)
        for (int c = 0; c < 3; ++c)
          rgb[3 * p + c] = splat::splat_channel8(img.rgba[4 * p + c]);
      char name[32];
      std::snprintf(name, sizeof name, "%06d", traj.frame_index.empty() ? static_cast<int>(i) : traj.frame_index[i]);
      // write_png and write_npy write a temporary file and rename it.
      scene::write_png((fs::path(a.output) / (std::string(name) + ".png")).string(), rgb.data(),
                       static_cast<int>(K.width), static_cast<int>(K.height), 3);
      if (a.depth)
        world::write_npy((fs::path(a.output) / (std::string(name) + "_depth.npy")).string(),
                         world::NpyArray::make<float>({K.height, K.width, 2}, img.depth));
      bar.update(i + 1, traj.size());
    }
    const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("splat render: %zu Gaussians (SH%u)%s, %zu frames %ux%u, %.1f ms/frame rendering, %.2f s total -> %s\n",
                max_count, sh_degree,
                scn.has_objects() ? (" incl. " + std::to_string(scn.objects.size()) + " dynamic object(s) (most in one frame)").c_str() : "",
                traj.size(), K.width, K.height, traj.size() ? render_ms / static_cast<double>(traj.size()) : 0.0,
                total_s, a.output.c_str());
  });
}

void print_cloud(const char* indent, const splat::GaussianCloud& c) {
  const splat::CloudSummary s = splat::summarize(c);
  // the first line continues the caller's line; the others are indented by `indent`
  std::printf("%zu Gaussians, SH degree %u (%u floats/Gaussian on the GPU incl. padding)\n", s.count, s.sh_degree,
              12u + (3u * c.sh_coeffs() + 3u) / 4u * 4u);
  if (s.count == 0) return;
  std::printf("%s  bounds   [%.3f, %.3f] x [%.3f, %.3f] x [%.3f, %.3f] m, centroid (%.3f, %.3f, %.3f)\n", indent,
              s.min.x, s.max.x, s.min.y, s.max.y, s.min.z, s.max.z, s.centroid.x, s.centroid.y, s.centroid.z);
  std::printf("%s  opacity  min %.4f mean %.4f max %.4f (after sigmoid)\n", indent, s.opacity_min, s.opacity_mean,
              s.opacity_max);
  std::printf("%s  scale    min %.3g median %.3g max %.3g m (after exp, all axes)\n", indent, s.scale_min,
              s.scale_median, s.scale_max);
}

void cmd_info(const std::string& path) {
  run_command([&](scene::Diagnostics&) {
    const splat::SplatScene scn = splat::read_splat_scene(path);
    if (!scn.has_objects() && scn.frames() == 0) {
      std::printf("%s: ", path.c_str());
      print_cloud("", scn.static_set);
      return;
    }
    std::printf("%s: splat scene, %zu frames, %zu dynamic object%s\n", path.c_str(), scn.frames(), scn.objects.size(),
                scn.objects.size() == 1 ? "" : "s");
    std::printf("  static set: ");
    print_cloud("  ", scn.static_set);
    size_t peak = 0, peak_frame = 0;
    for (size_t f = 0; f < scn.frames(); ++f) {
      size_t n = scn.static_set.size();
      for (const auto& o : scn.objects)
        if (o.pose(f)) n += o.gaussians.size();
      if (n > peak) peak = n, peak_frame = f;
    }
    for (const auto& o : scn.objects) {
      size_t present = 0, first = 0, last = 0;
      for (size_t f = 0; f < o.present.size(); ++f)
        if (o.present[f]) {
          if (present++ == 0) first = f;
          last = f;
        }
      std::printf("  object %lld (%s): %zu Gaussians, SH%u, present in %zu frames", static_cast<long long>(o.id),
                  o.source.c_str(), o.gaussians.size(), o.gaussians.sh_degree, present);
      if (present) {
        const glm::dvec3 a(o.poses[first][3]), b(o.poses[last][3]);
        std::printf(" (%zu..%zu), from (%.2f, %.2f, %.2f) to (%.2f, %.2f, %.2f)", first, last, a.x, a.y, a.z, b.x, b.y,
                    b.z);
      }
      std::printf("\n");
    }
    if (scn.frames() > 0) std::printf("  most Gaussians in one frame: %zu (frame %zu)\n", peak, peak_frame);
  });
}

void cmd_convert(const std::string& in, const std::string& out) {
  run_command([&](scene::Diagnostics& diag) {
    refuse_overwriting_input(in, out);
    const splat::GaussianCloud c = splat::read_gaussians(in);
    bool dropped = false;
    splat::write_gaussians(out, c, &dropped);
    if (dropped)
      diag.warn(out, "", ".splat keeps only the DC colour: SH degree " + std::to_string(c.sh_degree) +
                             " view dependence dropped");
    std::printf("splat convert: %zu Gaussians (SH%u) %s -> %s\n", c.size(), dropped ? 0u : c.sh_degree, in.c_str(),
                out.c_str());
  });
}

void add_splat_commands(CLI::App& app) {
  CLI::App& group = subcommand_group(app, "splat", "3D Gaussian splatting scenes: render, inspect and convert .ply/.splat files and scenes with dynamic objects");
  auto a = std::make_shared<SplatRenderArgs>();
  CLI::App* r = group.add_subcommand("render", "Render a 3DGS .ply/.splat or a splat scene .json (static + dynamic objects) along camera poses (GPU tile rasterizer)");
  r->add_option("scene", a->scene, "3DGS .ply (binary little-endian or ascii, SH degree 0-3), .splat, or a splat scene .json whose pose i renders frame i (later poses see the last frame)")
      ->required()
      ->type_name("SCENE");
  r->add_option("--camera", a->camera, "Pinhole intrinsics in pixels")->type_name("fx,fy,cx,cy,w,h");
  r->add_option("--trajectory", a->trajectory, "Poses: .npy [N,4,4] OpenCV camera-to-world (or icube-trajectory JSON)")
      ->required()
      ->type_name("POSES.npy");
  r->add_flag("--antialiased", a->antialiased, "Mip-Splatting 2-D filter compensation (for assets trained with it)");
  r->add_option("--near", a->near_z, "Near plane: view z <= Z is culled")->type_name("Z")->capture_default_str();
  r->add_option("--far", a->far_z, "Far plane: view z > Z is culled")->type_name("Z")->capture_default_str();
  r->add_option("--background", a->background, "Background colour")->type_name("r,g,b")->capture_default_str();
  r->add_option("--sky", a->sky,
                "Colour behind the Gaussians: background (the --background colour), gradient (z-up zenith/horizon/ground) "
                "or an equirectangular panorama .png (centre column looks along world +x, row 0 = zenith)")
      ->type_name("background|gradient|FILE.png")
      ->capture_default_str();
  r->add_flag("--integer-pixels", a->integer_pixels, "Sample pixel u at u (Inria) instead of u + 0.5 (gsplat)");
  r->add_flag("--depth", a->depth, "Also write NNNNNN_depth.npy (float32 [H,W,2]: expected, median depth)");
  r->add_option("-o,--output", a->output, "Output folder")->required()->type_name("OUTDIR");
  r->callback([a] { cmd_render(*a); });
  auto path = std::make_shared<std::string>();
  CLI::App* i = group.add_subcommand(
      "info", "Summarise a Gaussian file (count, SH degree, bounds, opacity, scale) or a scene .json (also its objects)");
  i->add_option("file", *path, "3DGS .ply, .splat or splat scene .json")->required()->type_name("FILE");
  i->callback([path] { cmd_info(*path); });
  auto conv = std::make_shared<std::pair<std::string, std::string>>();
  CLI::App* c = group.add_subcommand(
      "convert", "Convert between 3DGS .ply and antimatter15 .splat (by OUT's extension; .splat keeps the DC colour only)");
  c->add_option("in", conv->first, "3DGS .ply or .splat")->required()->type_name("IN");
  c->add_option("out", conv->second, "Output .ply (Inria layout) or .splat (32 B/Gaussian)")->required()->type_name("OUT");
  c->callback([conv] { cmd_convert(conv->first, conv->second); });
}

const CommandRegistrar kSplatRegistrar(add_splat_commands, 47);

}  // namespace

}  // namespace icube::tools
