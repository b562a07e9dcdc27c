// icube-view: --script events (commands: script.h); see app.h.
#include "app.h"

#include <algorithm>
#include <cstdio>

namespace icube::viewer {

void App::run_event(const ScriptEvent& e) {
  const std::string a = e.args.empty() ? "" : e.args[0];
  std::string rest;  // all arguments, space-separated (teleport labels)
  for (const std::string& s : e.args) rest += (rest.empty() ? "" : " ") + s;
  try {
    if (e.command == "down") script_keys.insert(a);
    else if (e.command == "up") script_keys.erase(a);
    else if (e.command == "mode") control = a == "fly" ? Control::Fly : Control::Drive;
    else if (e.command == "camera") chase = a == "chase";
    else if (e.command == "render") {
      for (size_t m = 0; m < std::size(kRenderModeNames); ++m)
        if (a == kRenderModeNames[m]) shade.mode = static_cast<RenderMode>(m);
    } else if (e.command == "view") {
      if (a == "gaussians" && !gauss) throw std::invalid_argument("no Gaussians loaded (open a package)");
      if (a == "voxels" && !have_world) throw std::invalid_argument("no voxel world loaded (Gaussians alone)");
      show_gaussians = a == "gaussians";
    } else if (e.command == "time") {
      if (timeline_frames() == 0) throw std::invalid_argument("no time line (no scene states, no moving objects)");
      time_index = std::clamp(std::stoi(a), 0, timeline_frames() - 1);
    } else if (e.command == "play") play_time = a == "on";
    else if (e.command == "scale") scale = eff_scale = std::stod(a);
    else if (e.command == "adaptive") adaptive = a == "on";
    else if (e.command == "shadows") shade.shadows = a == "on";
    else if (e.command == "ui") show_ui = a == "on";
    else if (e.command == "occupancy") renderer.raycaster().set_occupancy(a == "on");
    else if (e.command == "ao") {
      shade.ao_samples = a == "off" ? 0 : std::stoi(a);
    } else if (e.command == "zero-height") {
      ground.zero_height = a == "on";
      ground.zero_z = car.position.z;
    } else if (e.command == "autopilot") autopilot_on = a == "on" && !autopilot.path.empty();
    else if (e.command == "record") {
      if (a == "start") recorder.start_continuous(sim_time);
      else if (a == "stop") recorder.stop_continuous();
      else if (a == "key") keyframe();
      else if (a == "pass") end_pass();
      else recorder.clear();
    } else if (e.command == "save") save(a);
    else if (e.command == "load") load_recording(a.empty() ? std::string(out_path) : a);
    else if (e.command == "screenshot") request_screenshot(a);
    else if (e.command == "frame-shot") frame_shot(e.args.at(0), std::stoul(e.args.at(1)), std::stoul(e.args.at(2)));
    else if (e.command == "frame-shots" || e.command == "gaussian-shots") {
      // Every step-th frame of every loaded pass: PREFIX_p<P>_f<FFF>.png.
      const bool gaussians = e.command == "gaussian-shots";
      const size_t step = std::stoul(e.args.at(1));
      size_t n = 0;
      for (size_t p = 0; p < replay.size(); ++p)
        for (size_t f = 0; f < replay[p].size(); f += step) {
          char name[64];
          std::snprintf(name, sizeof name, "_p%zu_f%03zu.png", p, f);
          if (gaussians) gaussian_frame_shot(e.args.at(0) + name, p, f);
          else frame_shot(e.args.at(0) + name, p, f);
          ++n;
        }
      if (n == 0) throw std::invalid_argument(e.command + ": no loaded pass (load a trajectory first)");
      status = std::to_string(n) + (gaussians ? " Gaussian" : "") + " frame shots -> " + e.args.at(0) + "_p*_f*.png";
    } else if (e.command == "teleport") teleport(rest);
    else if (e.command == "quit") quit = true;
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "icube-view: error: script line %d (%s): %s\n", e.line, e.command.c_str(), ex.what());
    ++failures;
  }
  std::printf("icube-view: t=%.2f %s %s%s\n", sim_time, e.command.c_str(), rest.c_str(),
              status.empty() ? "" : ("  [" + status + "]").c_str());
}

}  // namespace icube::viewer
