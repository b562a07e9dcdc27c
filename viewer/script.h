// Scripted viewer sessions and frame statistics (CPU only; library icube_viewer_core).
//
// A script is a text file of timed events, one per line, '#' comments:
//   <seconds> <command> [arguments]
// Times are simulated seconds from the start (scripted and autopilot runs step
// the simulation by a fixed 1/30 s per frame, so a script gives the same
// trajectory on any machine), non-decreasing. Commands:
//   down KEY | up KEY          hold / release a key (W A S D, UP DOWN LEFT RIGHT, SPACE, SHIFT, Q E)
//   mode drive|fly             camera control mode
//   camera chase|dash          drive-mode view
//   render shaded|semantic|depth|instance|coords
//   scale S                    resolution scale (0.25 .. 1)
//   adaptive on|off            adaptive resolution
//   zero-height on|off         InfiniCube's "always zero height"
//   autopilot on|off           follow the scene's ego track
//   record start|stop|key|pass|clear   continuous 10 Hz on/off, keyframe, close the pass, forget all
//   save [PATH]                interpolate the passes and write .npy + JSON (PATH or --record-out)
//   screenshot [PATH]          PNG of the view (PATH or --screenshot-out)
//   teleport ego|origin|chunk N|feature N|LABEL   to the ego track start, the world's centre, the
//                              N-th chunk or map feature (teleport.h) or the map feature of that label
//   shadows on|off             sun shadows in the shaded mode
//   ui on|off                  the panels (F1)
//   occupancy on|off           the ray caster's occupancy masks (measurements)
//   ao off|K                   ambient occlusion with K rays per pixel (0..16)
//   load [PATH]                load a trajectory (PATH or --record-out) and replay it
//   frame-shot PATH P F        semantic PNG of frame F of loaded pass P as `icube buffers` renders it
//   frame-shots PREFIX S       the same for every S-th frame (0, S, 2S, ...) of every loaded pass:
//                              PREFIX_p<P>_f<FFF>.png (frame zero-padded to 3 digits)
//   view voxels|gaussians      the voxel views or a package's Gaussians (gaussian_view.h)
//   time N                     time index N (the scene's state; the Gaussians' frame)
//   play on|off                advance the time index at 10 Hz (the moving cars)
//   gaussian-shots PREFIX S    every S-th frame of every loaded pass drawn from the Gaussians as `icube
//                              splat render` draws it (target camera, whole set): PREFIX_p<P>_f<FFF>.png
//   quit                       end the session
// Parse errors throw std::invalid_argument "FILE:LINE: what".
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace icube::viewer {

struct ScriptEvent {
  double time = 0.0;
  std::string command;
  std::vector<std::string> args;
  int line = 0;
};

std::vector<ScriptEvent> parse_script(const std::string& text, const std::string& name);
std::vector<ScriptEvent> load_script(const std::string& path);

// Hands out the events that are due, in order.
class ScriptPlayer {
 public:
  explicit ScriptPlayer(std::vector<ScriptEvent> events) : events_(std::move(events)) {}
  std::vector<ScriptEvent> due(double t);
  bool done() const { return next_ >= events_.size(); }

 private:
  std::vector<ScriptEvent> events_;
  size_t next_ = 0;
};

// Frame times in milliseconds; percentiles by nearest rank.
struct FrameStats {
  std::vector<double> ms;
  void add(double v) { ms.push_back(v); }
  double percentile(double p) const;  // p in [0, 100]; 0 when empty
  double mean() const;
  std::string summary() const;  // "frames N  mean  p50  p90  p95  p99  max  (ms), fps at p50"
};

}  // namespace icube::viewer
