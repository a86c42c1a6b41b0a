#include "sim/core/table_file.h"

#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>

#include "sim/core/fnv.h"

namespace nvs {
namespace {
constexpr std::size_t kHead = 8 + sizeof(std::uint32_t) + 2 * sizeof(std::uint64_t);
}  // namespace

bool writeTableFile(const std::filesystem::path& file, const TableFileFormat& format,
                    std::uint64_t key, const std::string& payload) {
    Fnv1a sum(format.checksumBasis);
    sum.bytes(payload.data(), payload.size());
    std::error_code ec;
    std::filesystem::create_directories(file.parent_path(), ec);
    const auto tmp = file.string() + ".tmp." + std::to_string(::getpid());
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        out.write(format.magic, 8);
        out.write(reinterpret_cast<const char*>(&format.version), sizeof format.version);
        out.write(reinterpret_cast<const char*>(&key), sizeof key);
        const std::uint64_t size = payload.size();
        out.write(reinterpret_cast<const char*>(&size), sizeof size);
        out.write(payload.data(), static_cast<std::streamsize>(payload.size()));
        out.write(reinterpret_cast<const char*>(&sum.h), sizeof sum.h);
        if (!out) {
            std::filesystem::remove(tmp, ec);
            std::fprintf(stderr, "nvstim: warning: could not write %s cache %s\n", format.what,
                         file.c_str());
            return false;
        }
    }
    std::filesystem::rename(tmp, file, ec);
    if (ec) {
        std::filesystem::remove(tmp, ec);
        return false;
    }
    return true;
}

bool readTableFile(const std::filesystem::path& file, const TableFileFormat& format,
                   std::uint64_t key, std::string* payload, std::string* why) {
    std::ifstream in(file, std::ios::binary);
    if (!in) return (*why = "no cache file", false);
    const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (data.size() < kHead + sizeof(std::uint64_t) ||
        std::memcmp(data.data(), format.magic, 8) != 0) {
        return (*why = std::string("not an nvstim ") + format.what + " table", false);
    }
    std::uint32_t version = 0;
    std::uint64_t fileKey = 0, size = 0, stored = 0;
    std::memcpy(&version, data.data() + 8, sizeof version);
    std::memcpy(&fileKey, data.data() + 12, sizeof fileKey);
    std::memcpy(&size, data.data() + 20, sizeof size);
    if (version != format.version) {
        return (*why = "format version " + std::to_string(version) + ", expected " +
                       std::to_string(format.version),
                false);
    }
    if (fileKey != key) return (*why = "key mismatch (stale)", false);
    if (data.size() != kHead + size + sizeof(std::uint64_t)) return (*why = "truncated", false);
    *payload = data.substr(kHead, size);
    std::memcpy(&stored, data.data() + kHead + size, sizeof stored);
    Fnv1a sum(format.checksumBasis);
    sum.bytes(payload->data(), payload->size());
    if (sum.h != stored) return (*why = "checksum mismatch (corrupt)", false);
    return true;
}

}  // namespace nvs
