#pragma once
// Files for the core tests: temporary folders and small encoders, shared so that every test
// program makes and cleans its files the same way.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

namespace ps::test {

/// A folder under the system temp folder for this test program, `prefix` + the process id,
/// created on first use and removed when the program ends.
inline const std::filesystem::path& programTempDir(const std::string& prefix) {
  struct Dir {
    std::filesystem::path path;
    ~Dir() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  };
  static const Dir dir = [&] {
    Dir d{std::filesystem::temp_directory_path() / (prefix + std::to_string(::getpid()))};
    std::filesystem::create_directories(d.path);
    return d;
  }();
  return dir.path;
}

/// A fresh, empty folder for the running test: its name inside programTempDir(prefix), so it
/// goes when the program ends.
inline std::filesystem::path testTempDir(const std::string& prefix) {
  const std::filesystem::path d =
      programTempDir(prefix) / ::testing::UnitTest::GetInstance()->current_test_info()->name();
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

/// Standard base64 (RFC 4648, with padding), for glTF data URIs.
inline std::string base64(const std::vector<uint8_t>& bytes) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t v = uint32_t(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= uint32_t(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) v |= bytes[i + 2];
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? t[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? t[v & 63] : '=';
  }
  return out;
}

}  // namespace ps::test
