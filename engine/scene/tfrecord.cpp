// TFRecord framing and software CRC32C (see tfrecord.h for the layout).
//
// The CRC uses slicing by 8: table[k][b] is the CRC state after byte b
// followed by k zero bytes, so eight input bytes are folded per step. The
// tables are built at compile time from the reflected polynomial.
#include "scene/tfrecord.h"

#include "scene/input_error.h"

#include <array>

namespace icube::scene {
namespace {

constexpr uint32_t kCastagnoliReflected = 0x82F63B78u;
constexpr uint32_t kMaskDelta = 0xA282EAD8u;
constexpr size_t kHeaderBytes = 12;  // uint64 length + uint32 masked CRC of it
constexpr size_t kFooterBytes = 4;   // uint32 masked CRC of the payload

using CrcTables = std::array<std::array<uint32_t, 256>, 8>;

constexpr CrcTables make_crc_tables() {
  CrcTables t{};
  for (uint32_t b = 0; b < 256; ++b) {
    uint32_t c = b;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (c >> 1) ^ kCastagnoliReflected : c >> 1;
    t[0][b] = c;
  }
  for (size_t k = 1; k < 8; ++k)
    for (size_t b = 0; b < 256; ++b) t[k][b] = (t[k - 1][b] >> 8) ^ t[0][t[k - 1][b] & 0xffu];
  return t;
}

constexpr CrcTables kCrcTables = make_crc_tables();

uint32_t load_u32(const uint8_t* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

uint64_t load_u64(const uint8_t* p) { return uint64_t(load_u32(p)) | uint64_t(load_u32(p + 4)) << 32; }

std::string hex32(uint32_t v) {
  static const char* digits = "0123456789abcdef";
  std::string s = "0x00000000";
  for (int i = 0; i < 8; ++i) s[size_t(9 - i)] = digits[(v >> (4 * i)) & 0xfu];
  return s;
}

}  // namespace

uint32_t crc32c(const uint8_t* data, size_t size, uint32_t crc) {
  uint32_t c = ~crc;
  const auto& t = kCrcTables;
  while (size >= 8) {
    uint32_t lo = load_u32(data) ^ c, hi = load_u32(data + 4);
    c = t[7][lo & 0xffu] ^ t[6][(lo >> 8) & 0xffu] ^ t[5][(lo >> 16) & 0xffu] ^ t[4][lo >> 24] ^
        t[3][hi & 0xffu] ^ t[2][(hi >> 8) & 0xffu] ^ t[1][(hi >> 16) & 0xffu] ^ t[0][hi >> 24];
    data += 8;
    size -= 8;
  }
  while (size--) c = (c >> 8) ^ t[0][(c ^ *data++) & 0xffu];
  return ~c;
}

uint32_t mask_crc32c(uint32_t crc) { return ((crc >> 15) | (crc << 17)) + kMaskDelta; }

std::string tfrecord_where(size_t index, uint64_t offset) {
  return "record " + std::to_string(index) + " at byte " + std::to_string(offset);
}

void check_tfrecord_payload(const uint8_t* data, size_t size, const TfRecordSpan& record, size_t index,
                            const std::string& file) {
  // The span came from frame_tfrecords over the same data, so it is in bounds;
  // re-check anyway so that a mismatched span cannot read past the end.
  if (record.payload_offset > size || record.length > size - record.payload_offset ||
      size - record.payload_offset - record.length < kFooterBytes)
    throw InputError(file, tfrecord_where(index, record.offset), "record span lies outside the file");
  const uint8_t* payload = data + record.payload_offset;
  const uint32_t want = load_u32(payload + record.length);
  const uint32_t got = mask_crc32c(crc32c(payload, size_t(record.length)));
  if (got != want)
    throw InputError(file, tfrecord_where(index, record.offset),
                     "payload CRC32C mismatch (stored " + hex32(want) + ", computed " + hex32(got) +
                         "): the file is corrupt");
}

std::vector<TfRecordSpan> frame_tfrecords(const uint8_t* data, size_t size, const std::string& file,
                                          TfRecordCheck check) {
  std::vector<TfRecordSpan> records;
  size_t pos = 0;
  while (pos < size) {
    const size_t index = records.size();
    const size_t left = size - pos;
    if (left < kHeaderBytes)
      throw InputError(file, tfrecord_where(index, pos),
                       "truncated record header (" + std::to_string(left) + " of 12 bytes)");
    const uint64_t length = load_u64(data + pos);
    if (check.length_crc) {
      const uint32_t want = load_u32(data + pos + 8);
      const uint32_t got = mask_crc32c(crc32c(data + pos, 8));
      if (got != want)
        throw InputError(file, tfrecord_where(index, pos),
                         "length CRC32C mismatch (stored " + hex32(want) + ", computed " + hex32(got) +
                             "): not a TFRecord file, or corrupt");
    }
    const size_t body = left - kHeaderBytes;  // bytes available for payload + footer
    if (length > body)
      throw InputError(file, tfrecord_where(index, pos),
                       "length " + std::to_string(length) + " exceeds the " + std::to_string(body) +
                           " bytes left in the file (truncated?)");
    if (body - length < kFooterBytes)
      throw InputError(file, tfrecord_where(index, pos),
                       "truncated record: payload CRC missing (" + std::to_string(body - length) + " of 4 bytes)");
    TfRecordSpan r;
    r.offset = pos;
    r.payload_offset = pos + kHeaderBytes;
    r.length = length;
    if (check.payload_crc) check_tfrecord_payload(data, size, r, index, file);
    records.push_back(r);
    pos += kHeaderBytes + size_t(length) + kFooterBytes;
  }
  return records;
}

}  // namespace icube::scene
