// The byte-level half of the map file format (map_io.h): fields appended to a byte string
// in the file's layout, and read back from a bounds-checked source. Both spell a field as
// Field(name, value), so one Transfer function (map_layout.h) describes the layout for
// writing and reading alike. Internal to map_io: other code reads and writes maps with
// map_io.h.
//
// Layout of the field kinds: integers and floats little-endian as they are in memory; a
// bool is a u8 that must be 0 or 1; a string is a u64 byte count, then the bytes; a vector
// of strings a u64 count, then the strings; a vector of trivially copyable T a u64 count,
// then the elements packed; an Eigen row-major matrix a u64 row count, a u64 column count,
// then the values row by row.
//
// Thread-safe: each writer, reader and source is used by one thread at a time.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include "common/util/status.h"

// Arrays are copied between memory and the file with memcpy, which is only the
// little-endian IEEE layout the format specifies on a little-endian IEEE host.
#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "map_io copies arrays with memcpy and needs a little-endian host"
#endif

namespace sceneloc::map_io_internal {

template <typename T>
using IfArithmetic = std::enable_if_t<std::is_arithmetic_v<T>, int>;
template <typename T>
using IfPod = std::enable_if_t<std::is_trivially_copyable_v<T>, int>;

// Appends fields to a byte string in the file's layout. Field names are unused here;
// they let one TransferMap() describe the layout for both writing and reading.
class PayloadWriter {
 public:
  explicit PayloadWriter(std::string* out) : out_(out) {}

  template <typename T, IfArithmetic<T> = 0>
  void Field(const char* /*name*/, const T& value) {
    Append(&value, sizeof(T));
  }
  void Field(const char* name, const bool& value) { Field(name, uint8_t{value}); }
  void Field(const char* name, const std::string& value) {
    Field(name, uint64_t{value.size()});
    Append(value.data(), value.size());
  }
  void Field(const char* name, const std::vector<std::string>& values) {
    Field(name, uint64_t{values.size()});
    for (const std::string& value : values) Field(name, value);
  }
  template <typename T, IfPod<T> = 0>
  void Field(const char* name, const std::vector<T>& values) {
    Field(name, uint64_t{values.size()});
    Append(values.data(), values.size() * sizeof(T));
  }
  template <typename Derived>
  void Field(const char* name, const Eigen::PlainObjectBase<Derived>& m) {
    static_assert(Derived::IsRowMajor || Derived::ColsAtCompileTime == 1);
    Field(name, static_cast<uint64_t>(m.rows()));
    Field(name, static_cast<uint64_t>(m.cols()));
    Append(m.data(), static_cast<size_t>(m.size()) * sizeof(typename Derived::Scalar));
  }

 private:
  void Append(const void* data, size_t n) { out_->append(static_cast<const char*>(data), n); }

  std::string* out_;
};

// Where a PayloadReader's bytes come from: memory, or a file read as it is parsed (so a
// map is never held twice, and a file that shrinks under the reader is a read error, not
// a SIGBUS as it would be with mmap).
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  // Copies the next n bytes to `out`; an error when they cannot all be had.
  virtual Status Read(void* out, size_t n) = 0;
};

// Bytes already in memory. REQUIRES: as many bytes follow `data` as the reader is told
// the payload holds (the reader never asks for more).
class MemorySource : public ByteSource {
 public:
  explicit MemorySource(const char* data) : data_(data) {}
  Status Read(void* out, size_t n) override;

 private:
  const char* data_;  // the caller checked that enough bytes follow
};

// Reads fields in the file's layout from a bounds-checked buffer. The first failure
// sticks: later fields are left untouched and status() reports the first problem. A
// count is checked against the bytes left before anything is allocated for it.
class PayloadReader {
 public:
  // Reads `size` payload bytes from `source`.
  PayloadReader(ByteSource* source, size_t size) : source_(source), size_(size) {}

  const Status& status() const { return status_; }
  // Records a malformed payload (the first failure is kept).
  void Fail(const std::string& message) {
    if (status_.ok()) status_ = DataLoss(message);
  }
  size_t remaining() const { return size_ - pos_; }

  template <typename T, IfArithmetic<T> = 0>
  void Field(const char* name, T& value) {
    Copy(name, &value, sizeof(T));
  }
  // A u8 that must be 0 or 1.
  void Field(const char* name, bool& value);
  void Field(const char* name, std::string& value);
  void Field(const char* name, std::vector<std::string>& values);
  template <typename T, IfPod<T> = 0>
  void Field(const char* name, std::vector<T>& values) {
    uint64_t n = 0;
    Field(name, n);
    if (!Fits(name, n, sizeof(T))) return;
    values.resize(n);
    Copy(name, values.data(), n * sizeof(T));
  }
  template <typename Derived>
  void Field(const char* name, Eigen::PlainObjectBase<Derived>& m);

 private:
  // Whether `count` elements of `element_bytes` fit in what is left; records an error
  // if not (or if an earlier field failed). Checked before anything is allocated, so a
  // declared count can never ask for more memory than the payload holds.
  bool Fits(const char* name, uint64_t count, size_t element_bytes);
  void Copy(const char* name, void* out, size_t n);

  ByteSource* source_;
  size_t size_;
  size_t pos_ = 0;
  Status status_;
};

template <typename Derived>
void PayloadReader::Field(const char* name, Eigen::PlainObjectBase<Derived>& m) {
  constexpr int kCols = Derived::ColsAtCompileTime;
  static_assert(kCols != Eigen::Dynamic && (Derived::IsRowMajor || kCols == 1));
  uint64_t rows = 0, cols = 0;
  Field(name, rows);
  Field(name, cols);
  if (status_.ok() && cols != kCols) {
    Fail(std::string(name) + " has " + std::to_string(cols) + " columns, expected " +
         std::to_string(kCols));
  }
  if (!Fits(name, rows, kCols * sizeof(typename Derived::Scalar))) return;
  m.resize(static_cast<Eigen::Index>(rows), kCols);
  Copy(name, m.data(), static_cast<size_t>(m.size()) * sizeof(typename Derived::Scalar));
}

}  // namespace sceneloc::map_io_internal
