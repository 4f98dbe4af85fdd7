// Little helpers that append plain values and vectors of plain values to a byte buffer and read
// them back (engine and run-loop state inside a checkpoint's `extra` blob). Native byte order:
// the checkpoint layer checks the byte order of the file as a whole.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace demfem::dem::detail {

class ByteWriter {
public:
  template <class T> void value(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* b = reinterpret_cast<const std::byte*>(&v);
    buf_.insert(buf_.end(), b, b + sizeof(T));
  }
  template <class T> void vec(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    value(static_cast<std::uint64_t>(v.size()));
    const auto* b = reinterpret_cast<const std::byte*>(v.data());
    buf_.insert(buf_.end(), b, b + v.size() * sizeof(T));
  }
  void bytes(std::span<const std::byte> b) {
    value(static_cast<std::uint64_t>(b.size()));
    buf_.insert(buf_.end(), b.begin(), b.end());
  }
  [[nodiscard]] std::vector<std::byte>& buffer() { return buf_; }

private:
  std::vector<std::byte> buf_;
};

class ByteReader {
public:
  explicit ByteReader(std::span<const std::byte> b) : b_(b) {}
  template <class T> T value() {
    static_assert(std::is_trivially_copyable_v<T>);
    need(sizeof(T));
    T v;
    std::memcpy(&v, b_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  template <class T> void value(T& v) { v = value<T>(); }
  template <class T> void vec(std::vector<T>& v) {
    const auto n = value<std::uint64_t>();
    if (n > (b_.size() - pos_) / sizeof(T)) fail("vector longer than the data");
    v.resize(n);
    if (n > 0) std::memcpy(v.data(), b_.data() + pos_, n * sizeof(T));
    pos_ += n * sizeof(T);
  }
  std::span<const std::byte> bytes() {
    const auto n = value<std::uint64_t>();
    need(n);
    auto s = b_.subspan(pos_, n);
    pos_ += n;
    return s;
  }
  [[nodiscard]] bool at_end() const { return pos_ == b_.size(); }
  [[noreturn]] static void fail(const std::string& what) {
    throw std::runtime_error("engine state in checkpoint: " + what);
  }

private:
  void need(std::size_t n) const {
    if (n > b_.size() - pos_) fail("truncated");
  }
  std::span<const std::byte> b_;
  std::size_t pos_ = 0;
};

} // namespace demfem::dem::detail
