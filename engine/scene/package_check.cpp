#include "scene/package_check.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "scene/sha256.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <set>

namespace icube::scene {

namespace fs = std::filesystem;

PackageCheck check_package(const std::string& dir, bool hashes) {
  PackageCheck out;
  const fs::path root(dir);
  const fs::path manifest_path = root / kPackageManifest;
  std::error_code ec;
  if (!fs::is_directory(root, ec)) {
    out.problem = dir + ": not a folder";
    return out;
  }
  if (!fs::is_regular_file(manifest_path, ec)) {
    out.problem = manifest_path.string() + ": missing (the package is partial)";
    return out;
  }
  nlohmann::json m;
  try {
    m = nlohmann::json::parse(read_file(manifest_path.string()));
  } catch (const std::exception& e) {
    out.problem = manifest_path.string() + ": not JSON (" + printable(e.what(), 120) + ")";
    return out;
  }
  if (!m.is_object() || m.value("format", std::string()) != kPackageFormat) {
    out.problem = manifest_path.string() + ": \"format\" is not \"" + kPackageFormat + "\"";
    return out;
  }
  if (!m.contains("version") || !m["version"].is_number_integer() || m["version"].get<int>() != kPackageVersion) {
    out.problem = manifest_path.string() + ": \"version\" is not " + std::to_string(kPackageVersion);
    return out;
  }
  if (!m.contains("files") || !m["files"].is_object()) {
    out.problem = manifest_path.string() + ": no \"files\" object";
    return out;
  }
  out.fingerprint = m.value("fingerprint", std::string());
  std::set<std::string> listed;
  for (const auto& [rel, hash] : m["files"].items()) {
    const fs::path p = root / rel;
    if (rel.empty() || rel.find("..") != std::string::npos || fs::path(rel).is_absolute() || !hash.is_string()) {
      out.problem = manifest_path.string() + ": files: bad entry \"" + printable(rel) + "\"";
      return out;
    }
    listed.insert(fs::path(rel).generic_string());
    if (!fs::is_regular_file(p, ec)) {
      out.problem = p.string() + ": listed in the manifest but missing";
      return out;
    }
    if (hashes && sha256_file(p.string()) != hash.get<std::string>()) {
      out.problem = p.string() + ": SHA-256 differs from the manifest's (the file is corrupt or was changed)";
      return out;
    }
  }
  for (const auto& e : fs::recursive_directory_iterator(root, ec)) {
    if (!e.is_regular_file()) continue;
    const std::string rel = fs::relative(e.path(), root).generic_string();
    if (rel == kPackageManifest || listed.count(rel)) continue;
    out.problem = e.path().string() + ": not listed in the manifest";
    return out;
  }
  out.files = listed.size();
  out.complete = true;
  return out;
}

}  // namespace icube::scene
