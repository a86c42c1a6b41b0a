#pragma once
// A cached table on disk (the atmosphere's, the thermal band's): an 8-byte magic, the format
// version (u32), the inputs' key (u64), the payload's size (u64), the payload, and an FNV-1a
// checksum of the payload (u64), all little-endian as the machine writes them. Written to a
// temporary file and renamed, so that a reader never sees half a table; a cache that cannot be
// written is a warning, not an error (the table is rebuilt next time).

#include <cstdint>
#include <filesystem>
#include <string>

namespace nvs {

struct TableFileFormat {
    const char* magic;            // 8 bytes
    std::uint32_t version;        // the table's format version
    std::uint64_t checksumBasis;  // FNV-1a offset basis of the checksum (sim/core/fnv.h)
    const char* what;             // "atmosphere", "LWIR": for messages
};

// Writes `payload` under `key`; on failure prints "nvstim: warning: could not write WHAT cache
// FILE" and returns false.
bool writeTableFile(const std::filesystem::path& file, const TableFileFormat& format,
                    std::uint64_t key, const std::string& payload);

// Reads a file written by writeTableFile and checks magic, version, key, size and checksum.
// False with *why (no cache file, not a table, format version, key mismatch (stale), truncated,
// checksum mismatch (corrupt)) when any check fails.
bool readTableFile(const std::filesystem::path& file, const TableFileFormat& format,
                   std::uint64_t key, std::string* payload, std::string* why);

}  // namespace nvs
