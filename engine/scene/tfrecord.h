// TFRecord framing: splits an in-memory file into its records.
//
// Each record is, little-endian: uint64 payload length, uint32 masked
// CRC32C of those 8 bytes, the payload, uint32 masked CRC32C of the payload
// (../shared/reference/formats.md §1.1). Records follow each other back to
// back with nothing in between or after.
//
// CRC32C is Castagnoli (reflected polynomial 0x82F63B78, init and final xor
// 0xFFFFFFFF), computed in software (slicing by 8); crc32c("123456789") =
// 0xE3069283. mask(c) = ((c >> 15) | (c << 17)) + 0xA282EAD8.
//
// Errors are InputError(file, "record <i> at byte <offset>", what), where
// <offset> is the byte offset of that record's length field.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace icube::scene {

// CRC32C of `size` bytes, continuing from `crc` (the value returned for the
// bytes before; 0 to start).
uint32_t crc32c(const uint8_t* data, size_t size, uint32_t crc = 0);
uint32_t mask_crc32c(uint32_t crc);

struct TfRecordSpan {
  uint64_t offset = 0;          // byte offset of the length field
  uint64_t payload_offset = 0;  // byte offset of the payload (offset + 12)
  uint64_t length = 0;          // payload bytes
};

struct TfRecordCheck {
  bool length_crc = true;   // check the masked CRC32C of every length field
  bool payload_crc = true;  // check the masked CRC32C of every payload
};

// Frames every record of `data` (an entire file). Throws InputError on a
// truncated header or footer, a length that runs past the end of the data,
// or (when asked) a CRC mismatch. An empty input has no records.
std::vector<TfRecordSpan> frame_tfrecords(const uint8_t* data, size_t size, const std::string& file,
                                          TfRecordCheck check = {});

// Checks the payload CRC of one record framed without payload checks.
void check_tfrecord_payload(const uint8_t* data, size_t size, const TfRecordSpan& record, size_t index,
                            const std::string& file);

// "record <index> at byte <offset>", the `where` of every framing error.
std::string tfrecord_where(size_t index, uint64_t offset);

}  // namespace icube::scene
