// Every path and file name of an `icube generate` package (docs/generate.md),
// in one place: the writer (engine/pipeline/generate_package), `icube package
// verify` (package_check), `icube eval` (lift/package_eval), the lift's
// outputs and the viewer all take them from here.
//
//   manifest.json         inputs, options, stages, every file's SHA-256
//   world.icw  scene.json  trajectory.json
//   buffers/clip/...      the guidance buffers (InfiniCube's layout), buffers/contact_sheet.png
//   frames/               the appearance frames and frames.json
//   gaussians/            scene.json (the 3DGS scene), gaussians_static.ply, sky.png, lift_report.json, eval.png
//   preview/              flythrough.mp4, flythrough.png
#pragma once

#include <filesystem>
#include <string>

namespace icube::scene {

class PackageLayout {
 public:
  explicit PackageLayout(std::filesystem::path root) : root_(std::move(root)) {}
  const std::filesystem::path& root() const { return root_; }

  static constexpr const char* kManifest = "manifest.json";
  static constexpr const char* kClip = "clip";  // the one clip of the guidance buffers

  std::filesystem::path manifest() const { return root_ / kManifest; }
  std::filesystem::path world() const { return root_ / "world.icw"; }
  std::filesystem::path scene() const { return root_ / "scene.json"; }  // the scene as read, icube JSON
  std::filesystem::path trajectory() const { return root_ / "trajectory.json"; }
  std::filesystem::path buffers() const { return root_ / "buffers"; }
  std::filesystem::path clip() const { return buffers() / kClip; }
  std::filesystem::path contact_sheet() const { return buffers() / "contact_sheet.png"; }
  std::filesystem::path frames() const { return root_ / "frames"; }
  std::filesystem::path gaussians() const { return root_ / "gaussians"; }
  std::filesystem::path preview() const { return root_ / "preview"; }

  // Inside gaussians/ (lift/lift_output.h writes them into any folder).
  static constexpr const char* kSplatScene = "scene.json";
  static constexpr const char* kStaticPly = "gaussians_static.ply";
  static constexpr const char* kSky = "sky.png";
  static constexpr const char* kLiftReport = "lift_report.json";
  static constexpr const char* kLiftEval = "eval.png";
  std::filesystem::path splat_scene() const { return gaussians() / kSplatScene; }
  std::filesystem::path sky() const { return gaussians() / kSky; }
  std::filesystem::path lift_report() const { return gaussians() / kLiftReport; }

 private:
  std::filesystem::path root_;
};

}  // namespace icube::scene
