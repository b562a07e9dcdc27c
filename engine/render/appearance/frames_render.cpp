// Appearance frames along a trajectory; see frames_render.h.
#include "render/appearance/frames_render.h"

#include "render/appearance/lighting.h"
#include "render/buffers/dynamic_cars.h"
#include "render/buffers/overlay_world.h"
#include "scene/atomic_file.h"
#include "scene/png_write.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <future>
#include <stdexcept>
#include <thread>

namespace icube::render {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
}  // namespace

bool lamps_on(const AppearancePrompt& p) {
  return p.time == TimeOfDay::Night || p.time == TimeOfDay::Dusk || p.time == TimeOfDay::Dawn;
}

bool headlights_on(const AppearancePrompt& p) {
  return lamps_on(p) || p.weather == Weather::Rainy || p.weather == Weather::Foggy;
}

std::vector<WorldLight> frame_lights(const AppearancePrompt& p, const std::vector<WorldLight>& lamps,
                                     const scene::Scene* scene, int time_index) {
  std::vector<WorldLight> lights;
  if (lamps_on(p)) lights = lamps;
  if (scene && headlights_on(p)) {
    const std::vector<WorldLight> hl = headlights(*scene, time_index);
    lights.insert(lights.end(), hl.begin(), hl.end());
  }
  return lights;
}

FramesRenderStats render_frames(gpu::Context& ctx, OverlayWorld& world, const world::VoxelGrid& static_world,
                                const scene::Scene* scene, const world::TriangleMesh& mesh,
                                const PinholeIntrinsics& K, const Trajectory& traj, const std::string& prompt,
                                const FramesRenderOptions& o, const std::string& dir) {
  namespace fs = std::filesystem;
  if (traj.size() == 0) throw std::invalid_argument("frames: empty trajectory");
  FramesRenderStats st;
  const AppearancePrompt parsed = parse_prompt(prompt);
  const shader::AppearanceParams lighting = lighting_params(parsed, o.seed);
  std::vector<WorldLight> lamps;
  if (lamps_on(parsed)) lamps = street_lamps(static_world);
  st.lamps = lamps.size();
  for (const char* sub : {"rgb", "sky_mask", "instance"}) fs::create_directories(fs::path(dir) / sub);

  AppearanceRendererGpu renderer(ctx);
  DynamicCarOverlay cars(world, scene, mesh);
  DynamicCarCosts car_costs;
  const unsigned writers = std::max(1u, o.threads ? o.threads : std::thread::hardware_concurrency());
  std::vector<std::future<void>> pending;
  auto write_frame = [dir](size_t idx, AppearanceImage img) {
    const std::string name = frame_file_name(idx);
    const int w = static_cast<int>(img.width), h = static_cast<int>(img.height);
    const std::vector<uint8_t> rgb = img.rgb8(), sky = img.sky_mask8();
    const std::vector<uint16_t> inst = img.instance16();
    scene::write_file_atomic((fs::path(dir) / "rgb" / name).string(), scene::encode_png(rgb.data(), w, h, 3, scene::PngSpeed::Fast));
    scene::write_file_atomic((fs::path(dir) / "sky_mask" / name).string(), scene::encode_png(sky.data(), w, h, 1, scene::PngSpeed::Fast));
    scene::write_file_atomic((fs::path(dir) / "instance" / name).string(), scene::encode_png_gray16(inst.data(), w, h, scene::PngSpeed::Fast));
  };
  FramesMeta meta;
  meta.width = K.width;
  meta.height = K.height;
  meta.prompt = prompt;
  meta.parsed = parsed;
  meta.seed = o.seed;
  meta.K = K;
  meta.pixels = o.appearance.pixels;
  for (size_t f = 0; f < traj.size(); ++f) {
    const int ti = traj.time_index[f];
    cars.set_time(ti, car_costs);
    const std::vector<WorldLight> lights = frame_lights(parsed, lamps, scene, ti);
    st.max_lights = std::max(st.max_lights, lights.size());
    Camera cam;
    cam.K = K;
    cam.c2w = traj.c2w[f];
    const auto t0 = Clock::now();
    AppearanceImage img = renderer.render(world.world(), cam, lighting, lights, o.appearance);
    st.render_s += seconds_since(t0);
    const auto t1 = Clock::now();
    while (pending.size() >= writers) {
      pending.front().get();
      pending.erase(pending.begin());
    }
    st.write_s += seconds_since(t1);
    pending.push_back(std::async(std::launch::async, write_frame, f, std::move(img)));
    meta.source_frame_indices.push_back(traj.frame_index[f]);
    meta.source_time_indices.push_back(ti);
    meta.poses.push_back(traj.c2w[f]);
    ++st.frames;
    if (o.progress) o.progress(f + 1, traj.size());
  }
  const auto t1 = Clock::now();
  for (auto& p : pending) p.get();
  st.write_s += seconds_since(t1);
  st.cars_s = car_costs.cars_s + car_costs.overlay_s;
  if (!parsed.unknown.empty()) {
    std::string u;
    for (const std::string& w : parsed.unknown) u += (u.empty() ? "" : ", ") + w;
    meta.notes.push_back("prompt words not understood: " + u);
  }
  for (const std::string& n : parsed.notes) meta.notes.push_back(n);
  scene::write_file_atomic((fs::path(dir) / "frames_meta.json").string(), frames_meta_json(meta));
  return st;
}

}  // namespace icube::render
