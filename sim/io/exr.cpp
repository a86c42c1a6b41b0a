#include "sim/io/exr.h"

#include <Iex.h>
#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <utility>

#include "sim/core/error.h"
#include "sim/core/input_file.h"

namespace nvs::io {

namespace {

[[noreturn]] void fail(const std::string& name, const std::string& msg) {
    throw SetupError(FileLoc{name, 0, 0}, msg);
}

// An OpenEXR input stream over bytes in memory: the file is read (bounded, regular files only)
// before OpenEXR sees it. Reads past the end throw Iex::InputExc, as OpenEXR's own streams do.
class MemoryIStream final : public Imf::IStream {
  public:
    MemoryIStream(const std::string& name, std::string_view bytes)
        : Imf::IStream(name.c_str()), b_(bytes) {}
    bool isMemoryMapped() const override { return true; }
    char* readMemoryMapped(int n) override {
        const char* p = take(n);
        return const_cast<char*>(p);  // OpenEXR only reads through the pointer
    }
    bool read(char c[], int n) override {
        std::memcpy(c, take(n), static_cast<std::size_t>(n));
        return pos_ < b_.size();
    }
    std::uint64_t tellg() override { return pos_; }
    void seekg(std::uint64_t pos) override { pos_ = pos; }
    void clear() override {}

  private:
    const char* take(int n) {
        if (n < 0 || pos_ > b_.size() || static_cast<std::uint64_t>(n) > b_.size() - pos_) {
            throw Iex::InputExc("unexpected end of file");
        }
        const char* p = b_.data() + pos_;
        pos_ += static_cast<std::uint64_t>(n);
        return p;
    }
    std::string_view b_;
    std::uint64_t pos_ = 0;
};

// The OpenEXR header walked before OpenEXR reads it (file layout: openexr.com, "OpenEXR File
// Layout"): magic 20000630, a version word, then attributes "name\0type\0" int32 size, value,
// up to an empty name. OpenEXR 3.1 allocates what an attribute's size and the data window
// claim before it checks them against the file (a 360-byte file made it allocate 1.9 GB);
// here each size must fit in the bytes that remain, and the data window within the limits,
// first. Single-part scan-line files only (nvstim writes those): tiled, deep and multi-part
// files, whose chunk tables grow with other fields, are refused.
// Whether an attribute's stated size is the one OpenEXR will read for its type. OpenEXR reads a
// known type by its own layout, not by the stated size (a box2i is 16 bytes whatever the file
// says, a channel list runs to its empty name, a preview to width·height·4 bytes): where the
// two differ, its reading and this walk part ways, and it reads the next bytes as whatever they
// happen to be (a string's size of 1.9 GB, found by fuzzing). Types by the "OpenEXR File
// Layout" (openexr.com) and OpenEXR 3.1's ImfStandardAttributes; unknown types are read as
// opaque bytes of the stated size, as OpenEXR does.
bool exrAttributeSizeAgrees(std::string_view type, std::string_view v) {
    static constexpr std::pair<std::string_view, std::size_t> kFixed[] = {
        {"box2i", 16},      {"box2f", 16},   {"chromaticities", 32},
        {"compression", 1}, {"double", 8},   {"envmap", 1},
        {"float", 4},       {"int", 4},      {"keycode", 28},
        {"lineOrder", 1},   {"m33f", 36},    {"m33d", 72},
        {"m44f", 64},       {"m44d", 128},   {"rational", 8},
        {"tiledesc", 9},    {"timecode", 8}, {"v2i", 8},
        {"v2f", 8},         {"v2d", 16},     {"v3i", 12},
        {"v3f", 12},        {"v3d", 24},     {"deepImageState", 1}};
    for (const auto& [t, n] : kFixed)
        if (type == t) return v.size() == n;
    const auto le32 = [&v](std::size_t at) {
        std::uint32_t x = 0;
        for (int i = 3; i >= 0; --i)
            x = (x << 8) | static_cast<unsigned char>(v[at + static_cast<std::size_t>(i)]);
        return x;
    };
    if (type == "chlist") {
        // Entries "name\0" + 16 bytes, then an empty name: exactly the stated size.
        std::size_t at = 0;
        for (;;) {
            const std::size_t end = v.find('\0', at);
            if (end == std::string_view::npos) return false;
            if (end == at) return end + 1 == v.size();
            at = end + 1 + 16;
            if (at > v.size()) return false;
        }
    }
    if (type == "preview") {
        if (v.size() < 8) return false;
        return std::uint64_t{le32(0)} * le32(4) * 4 + 8 == v.size();
    }
    if (type == "stringvector") {
        std::size_t at = 0;
        while (at < v.size()) {
            if (v.size() - at < 4) return false;
            const std::uint32_t n = le32(at);
            at += 4;
            if (n > v.size() - at) return false;
            at += n;
        }
        return true;
    }
    if (type == "floatvector") return v.size() % 4 == 0;
    return true;  // string, opaque: read by the stated size
}

void checkExrHeader(std::string_view b, const std::string& name, const ImageLimits& limits) {
    const auto bad = [&name](const std::string& why) {
        throw SetupError(FileLoc{name}, "not a readable EXR file: " + why);
    };
    const auto u32 = [&b](std::size_t at) {
        std::uint32_t v = 0;
        for (int i = 3; i >= 0; --i)
            v = (v << 8) | static_cast<unsigned char>(b[at + static_cast<std::size_t>(i)]);
        return v;
    };
    if (b.size() < 8 || u32(0) != 20000630u) bad("no EXR magic number");
    const std::uint32_t version = u32(4);
    if ((version & 0xFFu) != 2u) bad("version " + std::to_string(version & 0xFFu));
    if ((version & 0x1A00u) != 0) bad("tiled, deep or multi-part files are not supported");
    const std::size_t maxName = (version & 0x400u) != 0 ? 255 : 31;
    std::size_t at = 8;
    const auto cstring = [&](const char* what) {
        const std::size_t end = b.find('\0', at);
        if (end == std::string_view::npos || end - at > maxName) bad(std::string("bad ") + what);
        const std::string_view v = b.substr(at, end - at);
        at = end + 1;
        return v;
    };
    bool window = false;
    for (;;) {
        const std::string_view attr = cstring("attribute name");
        if (attr.empty()) break;
        const std::string_view type = cstring("attribute type");
        if (b.size() - at < 4) bad("truncated header");
        const std::uint32_t size = u32(at);
        at += 4;
        if (size > b.size() - at) bad("attribute '" + std::string(attr) + "' larger than the file");
        if (!exrAttributeSizeAgrees(type, b.substr(at, size))) {
            bad("attribute '" + std::string(attr) + "' of type '" + std::string(type) +
                "' with a size its type does not have");
        }
        if (attr == "dataWindow") {
            if (type != "box2i" || size != 16) bad("bad dataWindow");
            const auto i32 = [&](std::size_t k) { return static_cast<std::int32_t>(u32(at + k)); };
            checkImageSize(std::int64_t{i32(8)} - i32(0) + 1, std::int64_t{i32(12)} - i32(4) + 1,
                           limits, name);
            window = true;
        }
        at += size;
    }
    if (!window) bad("no dataWindow");
}

}  // namespace

ExrImage parseExr(std::string_view bytes, const std::string& name, const ImageLimits& limits) {
    ExrImage r;
    checkExrHeader(bytes, name, limits);
    try {
        MemoryIStream stream(name, bytes);
        Imf::InputFile file(stream);
        const Imf::Header& hdr = file.header();
        const Imath::Box2i dw = hdr.dataWindow();
        // In 64 bits: the corners are any 32-bit integers.
        const std::int64_t w = std::int64_t{dw.max.x} - dw.min.x + 1;
        const std::int64_t h = std::int64_t{dw.max.y} - dw.min.y + 1;
        checkImageSize(w, h, limits, name);
        std::string channel;
        for (const char* c : {"Y", "R", "L"}) {
            if (hdr.channels().findChannel(c)) {
                channel = c;
                break;
            }
        }
        if (channel.empty()) {
            auto it = hdr.channels().begin();
            if (it == hdr.channels().end()) fail(name, "EXR has no channels");
            channel = it.name();
        }
        r.image = ImageF(static_cast<int>(w), static_cast<int>(h));
        Imf::FrameBuffer fb;
        // The slice's base is the address of pixel (0, 0) of the data window's coordinates
        // (OpenEXR's Slice convention), computed in integers: the data window may lie far from
        // the origin, and pointer arithmetic that far outside the image is undefined.
        const std::ptrdiff_t offset_px =
            static_cast<std::ptrdiff_t>(dw.min.y) * r.image.stride_px() + dw.min.x;
        char* base =  // NOLINT(performance-no-int-to-ptr): see above
            reinterpret_cast<char*>(reinterpret_cast<std::uintptr_t>(r.image.row(0)) -
                                    static_cast<std::uintptr_t>(offset_px) * sizeof(float));
        fb.insert(channel,
                  Imf::Slice(Imf::FLOAT, base, sizeof(float),
                             sizeof(float) * static_cast<std::size_t>(r.image.stride_px())));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        for (auto it = hdr.begin(); it != hdr.end(); ++it) {
            if (const auto* a = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) {
                r.strings.emplace_back(it.name(), a->value());
            }
        }
    } catch (const SetupError&) {
        throw;
    } catch (const std::exception& e) {
        fail(name, std::string("cannot read EXR: ") + e.what());
    }
    return r;
}

ExrImage readExr(const std::filesystem::path& path, const ImageLimits& limits) {
    return parseExr(readInputFile(path, kMaxImageFileBytes, "image file"), path.string(), limits);
}

std::string ExrImage::attribute(std::string_view name) const {
    for (const auto& [k, v] : strings)
        if (k == name) return v;
    return {};
}

namespace {

// An Imf::OStream on a file descriptor that keeps its first error. OpenEXR writes the line
// offset table in ~OutputFile and swallows what that throws (ImfOutputFile.cpp: "We cannot
// safely throw any exceptions from here"), so a failure there (a full disk) would otherwise
// pass unnoticed and leave a truncated file that looks written.
class CheckedFdStream final : public Imf::OStream {
  public:
    CheckedFdStream(const char* name, int fd) : Imf::OStream(name), fd_(fd) {}
    void write(const char c[], int n) override {
        if (rc_ != 0) throw std::runtime_error("earlier write failed");
        rc_ = writeAll(fd_, c, static_cast<std::size_t>(n));
        if (rc_ != 0) throw std::runtime_error(std::strerror(-rc_));
        pos_ += static_cast<std::uint64_t>(n);
    }
    std::uint64_t tellp() override { return pos_; }
    void seekp(std::uint64_t pos) override {
        if (::lseek(fd_, static_cast<off_t>(pos), SEEK_SET) < 0) {
            if (rc_ == 0) rc_ = -errno;
            throw std::runtime_error(std::strerror(-rc_));
        }
        pos_ = pos;
    }
    int rc() const { return rc_; }

  private:
    int fd_;
    std::uint64_t pos_ = 0;
    int rc_ = 0;
};

// writeExr with OpenEXR's message kept in `what`.
int writeExrTo(int fd, const char* name, ImageView<const float> img,
               const ExrAttributes& attributes, std::string& what) noexcept {
    CheckedFdStream stream(name, fd);
    int rc = 0;
    try {
        Imf::Header hdr(img.width(), img.height());
        hdr.channels().insert("Y", Imf::Channel(Imf::FLOAT));
        for (const auto& [k, v] : attributes.strings)
            hdr.insert(k, Imf::StringAttribute(v));
        for (const auto& [k, v] : attributes.ints)
            hdr.insert(k, Imf::IntAttribute(v));
        for (const auto& [k, v] : attributes.doubles)
            hdr.insert(k, Imf::DoubleAttribute(v));
        Imf::OutputFile file(stream, hdr);
        Imf::FrameBuffer fb;
        fb.insert(
            "Y",
            Imf::Slice(Imf::FLOAT, const_cast<char*>(reinterpret_cast<const char*>(img.row(0))),
                       sizeof(float), sizeof(float) * static_cast<std::size_t>(img.stride_px())));
        file.setFrameBuffer(fb);
        file.writePixels(img.height());
    } catch (const std::exception& e) {
        rc = -EIO;
        try {
            what = e.what();
        } catch (...) {
        }
    }
    // ~OutputFile has run: the stream knows whether the offsets reached the file.
    if (stream.rc() != 0) rc = stream.rc();
    return rc;
}

}  // namespace

int writeExr(int fd, const char* name, ImageView<const float> img,
             const ExrAttributes& attributes) noexcept {
    std::string what;
    return writeExrTo(fd, name, img, attributes, what);
}

void writeExr(const std::filesystem::path& path, ImageView<const float> img,
              const ExrAttributes& attributes) {
    FileOut out(path);
    std::string what;
    const int rc = writeExrTo(out.fd(), path.c_str(), img, attributes, what);
    if (rc == -EIO && !what.empty()) {
        out.close();
        fail(path.string(), "cannot write EXR: " + what);
    }
    out.close(rc, "cannot write EXR");
}

}  // namespace nvs::io
