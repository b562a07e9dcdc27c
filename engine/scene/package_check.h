// An `icube generate` package (docs/generate.md) checked against its
// manifest: manifest.json present and of the icube-package format, every file
// it lists present with the SHA-256 it records, and no file it does not list.
// A package that passes is complete; anything else is partial or corrupt,
// named by the first problem found. Tests: tests/scene/test_package_check.cpp.
#pragma once

#include "scene/package_layout.h"

#include <string>

namespace icube::scene {

inline constexpr const char* kPackageFormat = "icube-package";
inline constexpr int kPackageVersion = 1;
inline constexpr const char* kPackageManifest = PackageLayout::kManifest;

struct PackageCheck {
  bool complete = false;
  std::string problem;      // one line naming the file and what is wrong; empty when complete
  std::string fingerprint;  // the manifest's "fingerprint" (SHA-256 of its inputs and options)
  size_t files = 0;         // files listed in the manifest
};

// hashes = false checks presence and sizes only (fast: for opening a package,
// not for deciding that a batch may skip it).
PackageCheck check_package(const std::string& dir, bool hashes = true);

}  // namespace icube::scene
