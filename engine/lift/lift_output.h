// The folder a lift writes (`icube lift -o DIR`, `icube generate`'s
// gaussians/): gaussians_static.ply (3DGS Inria layout, SH0), sky.png
// (equirect panorama), scene.json (icube-splat-scene with the static set),
// lift_report.json (options, counts, timings, held-out PSNR per frame) and
// eval.png (held-out frames: the references above, the
// Gaussians below); with dynamic objects also object_<id>.ply per object (in
// its object frame) and their tracks in scene.json ("frames", "objects").
// Files are written atomically; the caller stages `dir`.
#pragma once

#include "lift/lift_frames.h"

#include <nlohmann/json_fwd.hpp>

#include <string>

namespace icube::lift {

inline constexpr const char* kLiftReportFormat = "icube-lift-report";

void write_lift_outputs(const std::string& dir, const render::FramesMeta& meta,
                        const LiftFramesResult& r, const LiftFramesOptions& o);

// The same files with a given lift_report.json (the learned lift's: lift_report() edited).
nlohmann::ordered_json lift_report(const render::FramesMeta& meta, const LiftFramesResult& r, const LiftFramesOptions& o);
void write_lift_outputs(const std::string& dir, const render::FramesMeta& meta, const LiftFramesResult& r,
                        const nlohmann::ordered_json& report);

}  // namespace icube::lift
