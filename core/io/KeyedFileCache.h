#pragma once
// A folder of checksummed cache entries, one file per 64-bit key: the storage under the bake's
// capture cache and eval's reference cache. An entry is written atomically (temp file + rename,
// so a killed process never leaves half an entry) and checked when read (size, magic, key,
// CRC-32), so a damaged entry is told apart from a missing one and never read as data.
//
// Entry layout, little-endian: char[8] magic, u64 key, payload, u32 CRC-32 of the bytes before
// it.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace ps {

class KeyedFileCache {
 public:
  /// Opens (creating when missing) the cache folder `dir`, whose entries are named
  /// `<16 hex digits of the key><extension>` and start with `magic`. `what` names the cache in
  /// errors ("capture cache"). Throws ps::FileError when the folder cannot be created.
  KeyedFileCache(std::filesystem::path dir, const std::array<char, 8>& magic, std::string extension,
                 const std::string& what);

  enum class Status { Missing, Damaged, Found };
  struct Lookup {
    Status status = Status::Missing;
    std::string payload;  ///< when Found
    std::string problem;  ///< when Damaged: what is wrong ("truncated: 100 bytes, expected 832")
  };

  /// The entry for `key`, whose payload must be `payloadBytes` long: any other size, magic, key
  /// or checksum makes it Damaged (the size is checked before anything is read).
  Lookup find(uint64_t key, size_t payloadBytes) const;
  /// Stores atomically, replacing any entry for `key`. The fsyncs are skipped (the entries are
  /// checksummed). Throws ps::FileError when the entry cannot be written.
  void store(uint64_t key, std::string_view payload) const;

  std::filesystem::path entryPath(uint64_t key) const;
  const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
  std::array<char, 8> magic_;
  std::string extension_;
};

}  // namespace ps
