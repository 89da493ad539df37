// Little-endian field access for the generated message structs.
// Header-only C++17: no heap, no exceptions; the same code runs on the ESP32-S3 and on Linux.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace jackson::protocol {

/// UTF-8 text of at most N bytes; on the wire it fills the rest of the payload.
template <size_t N>
struct Text {
  uint8_t len = 0;
  std::array<char, N> data{};

  /// Copies min(n, N) bytes.
  void assign(const void* src, size_t n) noexcept {
    len = static_cast<uint8_t>(n < N ? n : N);
    std::memcpy(data.data(), src, len);
  }
  /// Copies a NUL-terminated string, truncated to N bytes.
  void assign(const char* s) noexcept { assign(s, std::strlen(s)); }
  static constexpr size_t capacity() noexcept { return N; }
};

namespace wire {

template <class T>
size_t put(uint8_t* out, T v) noexcept {
  static_assert(std::is_arithmetic_v<T>, "scalar expected");
  if constexpr (std::is_floating_point_v<T>) {
    static_assert(sizeof(T) == 4, "only f32 is on the wire");
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    return put(out, bits);
  } else {
    using U = std::make_unsigned_t<T>;
    U u = static_cast<U>(v);
    for (size_t i = 0; i < sizeof(T); ++i) {
      out[i] = static_cast<uint8_t>(u >> (8 * i));
    }
    return sizeof(T);
  }
}

template <class T, size_t N>
size_t put(uint8_t* out, const std::array<T, N>& a) noexcept {
  size_t o = 0;
  for (const T& v : a) o += put(out + o, v);
  return o;
}

template <size_t N>
size_t put(uint8_t* out, const Text<N>& t) noexcept {
  std::memcpy(out, t.data.data(), t.len);
  return t.len;
}

template <class T>
size_t get(const uint8_t* in, T& v) noexcept {
  static_assert(std::is_arithmetic_v<T>, "scalar expected");
  if constexpr (std::is_floating_point_v<T>) {
    uint32_t bits = 0;
    get(in, bits);
    std::memcpy(&v, &bits, 4);
    return 4;
  } else {
    using U = std::make_unsigned_t<T>;
    U u = 0;
    for (size_t i = 0; i < sizeof(T); ++i) {
      u = static_cast<U>(u | static_cast<U>(static_cast<U>(in[i]) << (8 * i)));
    }
    v = static_cast<T>(u);
    return sizeof(T);
  }
}

template <class T, size_t N>
size_t get(const uint8_t* in, std::array<T, N>& a) noexcept {
  size_t o = 0;
  for (T& v : a) o += get(in + o, v);
  return o;
}

}  // namespace wire
}  // namespace jackson::protocol
