#include "core/io/KeyedFileCache.h"

#include <cstdio>
#include <cstring>
#include <system_error>

#include "core/common/Error.h"
#include "core/io/ProbeSetFile.h"
#include "core/io/SceneHash.h"
#include "core/io/VolumeFile.h"

namespace ps {

namespace {
constexpr size_t kHeaderBytes = 8 + 8;
constexpr size_t kCrcBytes = 4;
}  // namespace

KeyedFileCache::KeyedFileCache(std::filesystem::path dir, const std::array<char, 8>& magic,
                               std::string extension, const std::string& what)
    : dir_(std::move(dir)), magic_(magic), extension_(std::move(extension)) {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec || !std::filesystem::is_directory(dir_))
    throw FileError(dir_.string(), "", "cannot create the " + what + " folder");
}

std::filesystem::path KeyedFileCache::entryPath(uint64_t key) const {
  return dir_ / (sceneHashText(key) + extension_);
}

KeyedFileCache::Lookup KeyedFileCache::find(uint64_t key, size_t payloadBytes) const {
  Lookup r;
  const std::filesystem::path path = entryPath(key);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return r;
  r.status = Status::Damaged;
  if (!std::filesystem::is_regular_file(path, ec)) {
    r.problem = "not a regular file";
    return r;
  }
  const size_t expected = kHeaderBytes + payloadBytes + kCrcBytes;
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) {
    r.problem = "cannot read its size";
    return r;
  }
  if (size != expected) {
    r.problem = std::string(size < expected ? "truncated" : "too long") + ": " +
                std::to_string(size) + " bytes, expected " + std::to_string(expected);
    return r;
  }
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    r.problem = "cannot be opened";
    return r;
  }
  std::string buf(expected + 1, '\0');  // one more: a file grown since file_size() reads long
  const size_t n = std::fread(buf.data(), 1, buf.size(), f);
  std::fclose(f);
  if (n != expected) {
    r.problem = "read " + std::to_string(n) + " bytes, expected " + std::to_string(expected);
    return r;
  }
  buf.resize(expected);
  uint64_t stored;
  std::memcpy(&stored, buf.data() + 8, 8);
  uint32_t crc;
  std::memcpy(&crc, buf.data() + expected - kCrcBytes, 4);
  if (std::memcmp(buf.data(), magic_.data(), 8) != 0) {
    r.problem = "not a cache entry of this kind (bad magic)";
  } else if (stored != key) {
    r.problem = "holds key " + sceneHashText(stored) + ", not " + sceneHashText(key);
  } else if (crc32(buf.data(), expected - kCrcBytes) != crc) {
    r.problem = "CRC-32 mismatch (corrupted)";
  } else {
    r.status = Status::Found;
    r.payload = buf.substr(kHeaderBytes, payloadBytes);
  }
  return r;
}

void KeyedFileCache::store(uint64_t key, std::string_view payload) const {
  std::string buf;
  buf.reserve(kHeaderBytes + payload.size() + kCrcBytes);
  buf.append(magic_.data(), 8);
  buf.append(reinterpret_cast<const char*>(&key), 8);
  buf.append(payload);
  const uint32_t crc = crc32(buf.data(), buf.size());
  buf.append(reinterpret_cast<const char*>(&crc), 4);
  writeFileAtomic(entryPath(key), buf, /*durable=*/false);
}

}  // namespace ps
