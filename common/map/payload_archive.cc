#include "common/map/payload_archive.h"

#include <cstring>

namespace sceneloc::map_io_internal {

Status MemorySource::Read(void* out, size_t n) {
  if (n > 0) std::memcpy(out, data_, n);
  data_ += n;
  return Status::Ok();
}

void PayloadReader::Field(const char* name, bool& value) {
  uint8_t byte = 0;
  Field(name, byte);
  if (byte > 1) Fail(std::string(name) + " is " + std::to_string(byte) + ", must be 0 or 1");
  value = byte == 1;
}

void PayloadReader::Field(const char* name, std::string& value) {
  uint64_t n = 0;
  Field(name, n);
  if (!Fits(name, n, 1)) return;
  value.resize(n);
  Copy(name, value.data(), n);
}

void PayloadReader::Field(const char* name, std::vector<std::string>& values) {
  uint64_t n = 0;
  Field(name, n);
  if (!Fits(name, n, sizeof(uint64_t))) return;  // each string has at least its count
  values.resize(n);
  for (size_t i = 0; i < n && status_.ok(); ++i) Field(name, values[i]);
}

bool PayloadReader::Fits(const char* name, uint64_t count, size_t element_bytes) {
  if (!status_.ok()) return false;
  if (count <= remaining() / element_bytes) return true;
  Fail(std::string(name) + " at payload offset " + std::to_string(pos_) + " declares " +
       std::to_string(count) + " elements of " + std::to_string(element_bytes) +
       " bytes but only " + std::to_string(remaining()) + " bytes are left");
  return false;
}

void PayloadReader::Copy(const char* name, void* out, size_t n) {
  if (!status_.ok()) return;
  if (n > remaining()) {
    Fail(std::string(name) + " at payload offset " + std::to_string(pos_) + " needs " +
         std::to_string(n) + " bytes but only " + std::to_string(remaining()) + " are left");
    return;
  }
  if (Status read = source_->Read(out, n); !read.ok()) {
    status_ = read;
    return;
  }
  pos_ += n;
}

}  // namespace sceneloc::map_io_internal
