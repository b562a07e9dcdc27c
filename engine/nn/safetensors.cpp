// .safetensors reader and writer; see safetensors.h.
#include "nn/safetensors.h"

#include "kernels/nn/cpu_tensor.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <set>
#include <stdexcept>
#include <utility>

namespace icube::nn {

namespace {

constexpr uint64_t kMaxHeaderBytes = 100'000'000;  // the reference implementation's limit

std::string name_text(std::string_view name) {
  std::string s(1, '\'');
  s.append(scene::printable(name));
  s.push_back('\'');
  return s;
}

}  // namespace

size_t dtype_size(DType t) {
  switch (t) {
    case DType::F32:
    case DType::I32: return 4;
    case DType::I64: return 8;
    case DType::U8:
    case DType::BOOL: return 1;
    default: return 2;
  }
}

bool dtype_is_float(DType t) { return t == DType::F32 || t == DType::F16 || t == DType::BF16; }

const char* dtype_name(DType t) {
  switch (t) {
    case DType::F32: return "F32";
    case DType::F16: return "F16";
    case DType::BF16: return "BF16";
    case DType::I64: return "I64";
    case DType::I32: return "I32";
    case DType::U8: return "U8";
    default: return "BOOL";
  }
}

uint64_t TensorInfo::numel() const {
  uint64_t n = 1;
  for (int64_t d : shape) n *= static_cast<uint64_t>(d);
  return n;
}

std::string TensorInfo::shape_text() const { return nn::shape_text(shape); }

SafetensorsFile::SafetensorsFile(const std::string& path) {
  path_ = path;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw scene::InputError(path, "", std::string("cannot open: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw scene::InputError(path, "", "not a regular file");
  }
  size_ = static_cast<size_t>(st.st_size);
  if (size_ > 0) {
    void* m = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
    if (m == MAP_FAILED) {
      const int err = errno;
      ::close(fd);
      throw scene::InputError(path, "", std::string("cannot map: ") + std::strerror(err));
    }
    map_ = m;
    base_ = static_cast<const uint8_t*>(m);
  }
  ::close(fd);
  try {
    parse();
  } catch (...) {
    if (map_) ::munmap(map_, size_);
    map_ = nullptr;
    throw;
  }
}

SafetensorsFile SafetensorsFile::from_bytes(std::string bytes, const std::string& name) {
  SafetensorsFile f;
  f.path_ = name;
  f.owned_ = std::move(bytes);
  f.base_ = reinterpret_cast<const uint8_t*>(f.owned_.data());
  f.size_ = f.owned_.size();
  f.parse();
  return f;
}

SafetensorsFile::SafetensorsFile(SafetensorsFile&& o) noexcept { *this = std::move(o); }

SafetensorsFile& SafetensorsFile::operator=(SafetensorsFile&& o) noexcept {
  if (this == &o) return *this;
  if (map_) ::munmap(map_, size_);
  const bool owned = o.base_ && !o.map_;
  const size_t data_offset = o.data_ ? static_cast<size_t>(o.data_ - o.base_) : 0;
  path_ = std::move(o.path_);
  owned_ = std::move(o.owned_);
  map_ = std::exchange(o.map_, nullptr);
  size_ = o.size_;
  base_ = owned ? reinterpret_cast<const uint8_t*>(owned_.data()) : o.base_;
  data_ = o.data_ ? base_ + data_offset : nullptr;
  header_bytes_ = o.header_bytes_;
  data_size_ = o.data_size_;
  tensors_ = std::move(o.tensors_);
  metadata_ = std::move(o.metadata_);
  o.base_ = o.data_ = nullptr;
  o.size_ = 0;
  return *this;
}

SafetensorsFile::~SafetensorsFile() {
  if (map_) ::munmap(map_, size_);
}

void SafetensorsFile::parse() {
  using scene::InputError;
  if (size_ < 8)
    throw InputError(path_, "byte 0", std::to_string(size_) + " bytes, shorter than the 8-byte header length");
  uint64_t n = 0;
  for (int i = 7; i >= 0; --i) n = (n << 8) | base_[i];
  if (n > kMaxHeaderBytes)
    throw InputError(path_, "byte 0", "header length " + std::to_string(n) + " is over the 100 MB limit");
  if (n > size_ - 8)
    throw InputError(path_, "byte 0",
                     "header length " + std::to_string(n) + " runs past the end of the file (" + std::to_string(size_) +
                         " bytes)");
  header_bytes_ = n;
  data_ = base_ + 8 + n;
  data_size_ = size_ - 8 - n;
  const std::string_view text(reinterpret_cast<const char*>(base_ + 8), n);
  if (text.empty() || text.front() != '{') throw InputError(path_, "header", "does not start with '{'");

  // Duplicate keys of the top-level object are an error (nlohmann would keep the last).
  std::set<std::string> seen;
  std::string duplicate;
  const nlohmann::json::parser_callback_t cb = [&](int depth, nlohmann::json::parse_event_t event,
                                                   nlohmann::json& parsed) {
    if (event == nlohmann::json::parse_event_t::key && depth == 1 && duplicate.empty() &&
        !seen.insert(parsed.get<std::string>()).second)
      duplicate = parsed.get<std::string>();
    return true;
  };
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text.begin(), text.end(), cb);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path_, "header", std::string("not valid JSON: ") + scene::printable(e.what(), 160));
  }
  if (!j.is_object()) throw InputError(path_, "header", "is not a JSON object");
  if (!duplicate.empty()) throw InputError(path_, "header", "key " + name_text(duplicate) + " appears twice");

  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& key = it.key();
    const nlohmann::json& v = it.value();
    if (key == "__metadata__") {
      if (!v.is_object()) throw InputError(path_, "__metadata__", "is not an object");
      for (auto m = v.begin(); m != v.end(); ++m) {
        if (!m.value().is_string())
          throw InputError(path_, "__metadata__", "value of " + name_text(m.key()) + " is not a string");
        metadata_[m.key()] = m.value().get<std::string>();
      }
      continue;
    }
    const std::string where = "tensor " + name_text(key);
    if (!v.is_object()) throw InputError(path_, where, "entry is not an object");
    for (auto f = v.begin(); f != v.end(); ++f)
      if (f.key() != "dtype" && f.key() != "shape" && f.key() != "data_offsets")
        throw InputError(path_, where, "unknown field " + name_text(f.key()));
    TensorInfo t;
    t.name = key;
    const auto dt = v.find("dtype");
    if (dt == v.end() || !dt->is_string()) throw InputError(path_, where, "no \"dtype\" string");
    const std::string d = dt->get<std::string>();
    if (d == "F32") t.dtype = DType::F32;
    else if (d == "F16") t.dtype = DType::F16;
    else if (d == "BF16") t.dtype = DType::BF16;
    else if (d == "I64") t.dtype = DType::I64;
    else if (d == "I32") t.dtype = DType::I32;
    else if (d == "U8") t.dtype = DType::U8;
    else if (d == "BOOL") t.dtype = DType::BOOL;
    else throw InputError(path_, where, "dtype " + name_text(d) + " is not F32, F16, BF16, I64, I32, U8 or BOOL");
    const auto sh = v.find("shape");
    if (sh == v.end() || !sh->is_array()) throw InputError(path_, where, "no \"shape\" array");
    uint64_t numel = 1;
    bool overflow = false;
    for (const nlohmann::json& e : *sh) {
      if (!e.is_number_integer() || (e.is_number_integer() && !e.is_number_unsigned() && e.get<int64_t>() < 0))
        throw InputError(path_, where, "shape entry " + scene::printable(e.dump(), 24) + " is not a non-negative integer");
      const uint64_t dim = e.get<uint64_t>();
      if (dim > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) overflow = true;
      else if (dim != 0 && numel > std::numeric_limits<uint64_t>::max() / dim) overflow = true;
      else numel *= dim;
      t.shape.push_back(static_cast<int64_t>(std::min<uint64_t>(dim, std::numeric_limits<int64_t>::max())));
    }
    if (overflow || numel > std::numeric_limits<uint64_t>::max() / dtype_size(t.dtype))
      throw InputError(path_, where, "shape " + t.shape_text() + " is too large");
    const auto off = v.find("data_offsets");
    if (off == v.end() || !off->is_array() || off->size() != 2 || !(*off)[0].is_number_unsigned() ||
        !(*off)[1].is_number_unsigned())
      throw InputError(path_, where, "\"data_offsets\" is not two non-negative integers");
    t.begin = (*off)[0].get<uint64_t>();
    t.end = (*off)[1].get<uint64_t>();
    if (t.end < t.begin)
      throw InputError(path_, where, "data_offsets [" + std::to_string(t.begin) + ", " + std::to_string(t.end) +
                                         "] end before they begin");
    const uint64_t want = numel * dtype_size(t.dtype);
    if (t.end - t.begin != want)
      throw InputError(path_, where, "shape " + t.shape_text() + " of " + d + " needs " + std::to_string(want) +
                                         " bytes, data_offsets give " + std::to_string(t.end - t.begin));
    if (t.end > data_size_)
      throw InputError(path_, where, "data_offsets end at " + std::to_string(t.end) + ", past the " +
                                         std::to_string(data_size_) + "-byte data section");
    tensors_.push_back(std::move(t));
  }
  // The ranges tile the data section: no overlap, no gap, nothing after the last.
  std::vector<const TensorInfo*> by_offset;
  for (const TensorInfo& t : tensors_) by_offset.push_back(&t);
  std::sort(by_offset.begin(), by_offset.end(), [](const TensorInfo* a, const TensorInfo* b) {
    return a->begin != b->begin ? a->begin < b->begin : a->end < b->end;
  });
  uint64_t at = 0;
  for (const TensorInfo* t : by_offset) {
    if (t->begin < at)
      throw InputError(path_, "tensor " + name_text(t->name),
                       "bytes [" + std::to_string(t->begin) + ", " + std::to_string(t->end) + ") overlap another tensor");
    if (t->begin > at)
      throw InputError(path_, "tensor " + name_text(t->name),
                       "a gap of " + std::to_string(t->begin - at) + " unclaimed bytes before it in the data section");
    at = t->end;
  }
  if (at != data_size_)
    throw InputError(path_, "byte " + std::to_string(8 + header_bytes_ + at),
                     std::to_string(data_size_ - at) + " bytes after the last tensor belong to no tensor");
  std::sort(tensors_.begin(), tensors_.end(), [](const TensorInfo& a, const TensorInfo& b) { return a.name < b.name; });
}

const TensorInfo* SafetensorsFile::find(std::string_view name) const {
  const auto it = std::lower_bound(tensors_.begin(), tensors_.end(), name,
                                   [](const TensorInfo& t, std::string_view n) { return t.name < n; });
  return it != tensors_.end() && it->name == name ? &*it : nullptr;
}

std::span<const uint8_t> SafetensorsFile::bytes(const TensorInfo& t) const {
  return {data_ + t.begin, static_cast<size_t>(t.end - t.begin)};
}

std::vector<float> SafetensorsFile::to_f32(const TensorInfo& t) const {
  const std::span<const uint8_t> b = bytes(t);
  const size_t n = static_cast<size_t>(t.numel());
  std::vector<float> out(n);
  if (t.dtype == DType::F32) {
    if (n) std::memcpy(out.data(), b.data(), n * 4);
    return out;
  }
  if (!dtype_is_float(t.dtype)) {
    const std::vector<int64_t> v = to_i64(t);
    for (size_t i = 0; i < n; ++i) out[i] = static_cast<float>(v[i]);
    return out;
  }
  for (size_t i = 0; i < n; ++i) {
    const uint16_t h = static_cast<uint16_t>(b[2 * i] | (b[2 * i + 1] << 8));
    out[i] = t.dtype == DType::F16 ? half_to_float(h) : bf16_to_float(h);
  }
  return out;
}

std::vector<int64_t> SafetensorsFile::to_i64(const TensorInfo& t) const {
  const std::span<const uint8_t> b = bytes(t);
  const size_t n = static_cast<size_t>(t.numel());
  std::vector<int64_t> out(n);
  for (size_t i = 0; i < n; ++i) {
    switch (t.dtype) {
      case DType::I64: std::memcpy(&out[i], b.data() + 8 * i, 8); break;
      case DType::I32: {
        int32_t v;
        std::memcpy(&v, b.data() + 4 * i, 4);
        out[i] = v;
        break;
      }
      case DType::U8:
      case DType::BOOL: out[i] = b[i]; break;
      default: throw std::invalid_argument("SafetensorsFile::to_i64: tensor '" + t.name + "' holds floats");
    }
  }
  return out;
}

int64_t SafetensorsFile::first_non_finite(const TensorInfo& t) const {
  if (!dtype_is_float(t.dtype)) return -1;
  const std::span<const uint8_t> b = bytes(t);
  const size_t n = static_cast<size_t>(t.numel());
  for (size_t i = 0; i < n; ++i) {
    bool finite;
    if (t.dtype == DType::F32) {
      uint32_t u;
      std::memcpy(&u, b.data() + 4 * i, 4);
      finite = (u & 0x7F800000u) != 0x7F800000u;
    } else {
      const uint16_t h = static_cast<uint16_t>(b[2 * i] | (b[2 * i + 1] << 8));
      finite = t.dtype == DType::F16 ? (h & 0x7C00u) != 0x7C00u : (h & 0x7F80u) != 0x7F80u;
    }
    if (!finite) return static_cast<int64_t>(i);
  }
  return -1;
}

TensorToWrite f32_tensor(std::string name, std::vector<int64_t> shape, const std::vector<float>& values) {
  TensorToWrite t;
  t.name = std::move(name);
  t.shape = std::move(shape);
  t.bytes.resize(values.size() * 4);
  if (!values.empty()) std::memcpy(t.bytes.data(), values.data(), t.bytes.size());
  return t;
}

TensorToWrite i32_tensor(std::string name, std::vector<int64_t> shape, const std::vector<int32_t>& values) {
  TensorToWrite t;
  t.name = std::move(name);
  t.dtype = DType::I32;
  t.shape = std::move(shape);
  t.bytes.resize(values.size() * 4);
  if (!values.empty()) std::memcpy(t.bytes.data(), values.data(), t.bytes.size());
  return t;
}

TensorToWrite u8_tensor(std::string name, std::vector<int64_t> shape, const std::vector<uint8_t>& values) {
  TensorToWrite t;
  t.name = std::move(name);
  t.dtype = DType::U8;
  t.shape = std::move(shape);
  t.bytes = values;
  return t;
}

std::string safetensors_bytes(const std::vector<TensorToWrite>& tensors,
                              const std::map<std::string, std::string>& metadata) {
  nlohmann::ordered_json h = nlohmann::ordered_json::object();
  if (!metadata.empty()) {
    nlohmann::ordered_json m = nlohmann::ordered_json::object();
    for (const auto& [k, v] : metadata) m[k] = v;
    h["__metadata__"] = m;
  }
  uint64_t at = 0;
  for (const TensorToWrite& t : tensors) {
    uint64_t numel = 1;
    for (int64_t d : t.shape) {
      if (d < 0) throw std::invalid_argument("safetensors: negative dimension in " + t.name);
      numel *= static_cast<uint64_t>(d);
    }
    if (numel * dtype_size(t.dtype) != t.bytes.size())
      throw std::invalid_argument("safetensors: " + t.name + " has " + std::to_string(t.bytes.size()) +
                                  " bytes for its shape");
    if (h.contains(t.name) || t.name == "__metadata__")
      throw std::invalid_argument("safetensors: tensor name " + t.name + " twice or reserved");
    h[t.name] = {{"dtype", dtype_name(t.dtype)}, {"shape", t.shape}, {"data_offsets", {at, at + t.bytes.size()}}};
    at += t.bytes.size();
  }
  std::string header = h.dump();
  header.append((8 - header.size() % 8) % 8, ' ');
  std::string out(8, '\0');
  const uint64_t n = header.size();
  for (int i = 0; i < 8; ++i) out[static_cast<size_t>(i)] = static_cast<char>((n >> (8 * i)) & 0xFFu);
  out += header;
  out.reserve(out.size() + at);
  for (const TensorToWrite& t : tensors) out.append(reinterpret_cast<const char*>(t.bytes.data()), t.bytes.size());
  return out;
}

void write_safetensors(const std::string& path, const std::vector<TensorToWrite>& tensors,
                       const std::map<std::string, std::string>& metadata) {
  scene::write_file_atomic(path, safetensors_bytes(tensors, metadata));
}

}  // namespace icube::nn
