#include "sim/sensor/image_io.h"

#include <Iex.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <fcntl.h>
#include <png.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "sim/core/error.h"
#include "sim/core/input_file.h"

namespace nvs::sensor {

namespace {

[[noreturn]] void fail(const std::filesystem::path& p, const std::string& msg) {
    throw SetupError(FileLoc{p.string(), 0, 0}, msg);
}

[[noreturn]] void fail(const std::string& name, const std::string& msg) {
    throw SetupError(FileLoc{name, 0, 0}, msg);
}

std::string lower(std::string s) {
    for (char& ch : s)
        ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return s;
}

// A PNM/PFM header read from memory (netpbm pgm(5), pfm: magic, then whitespace-separated
// decimal fields, '#' comments, and exactly one whitespace byte before the samples). Each
// field is bounded: at most 32 characters, integers of at most 9 digits.
class HeaderReader {
  public:
    HeaderReader(std::string_view bytes, const std::string& name) : b_(bytes), name_(name) {}
    std::string_view token() {
        for (;;) {
            while (i_ < b_.size() && std::isspace(static_cast<unsigned char>(b_[i_])) != 0)
                ++i_;
            if (i_ < b_.size() && b_[i_] == '#') {
                while (i_ < b_.size() && b_[i_] != '\n')
                    ++i_;
                continue;
            }
            break;
        }
        const std::size_t from = i_;
        while (i_ < b_.size() && std::isspace(static_cast<unsigned char>(b_[i_])) == 0 &&
               i_ - from <= 32)
            ++i_;
        const std::string_view t = b_.substr(from, i_ - from);
        if (t.empty() || t.size() > 32) bad("truncated or overlong header field");
        if (i_ < b_.size()) ++i_;  // the single whitespace byte after the field, if any
        return t;
    }
    int positive(const char* what) {
        const std::string_view t = token();
        int v = 0;
        const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
        if (t.size() > 9 || r.ec != std::errc() || r.ptr != t.data() + t.size() || v <= 0) {
            bad(std::string("bad ") + what + " '" + std::string(t) + "'");
        }
        return v;
    }
    double real(const char* what) {
        std::string_view t = token();
        if (!t.empty() && t[0] == '+') t.remove_prefix(1);
        double v = 0.0;
        const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
        if (r.ec != std::errc() || r.ptr != t.data() + t.size() || !std::isfinite(v)) {
            bad(std::string("bad ") + what + " '" + std::string(t) + "'");
        }
        return v;
    }
    // The samples after the header: exactly `bytes` of them must be there.
    std::string_view samples(std::uint64_t bytes) {
        const std::uint64_t left = i_ <= b_.size() ? b_.size() - i_ : 0;
        if (left < bytes) {
            bad("header promises " + std::to_string(bytes) + " bytes of samples, the file holds " +
                std::to_string(left));
        }
        return b_.substr(i_, static_cast<std::size_t>(bytes));
    }
    [[noreturn]] void bad(const std::string& msg) const { throw SetupError(FileLoc{name_}, msg); }

  private:
    std::string_view b_;
    const std::string& name_;
    std::size_t i_ = 0;
};

// The image size a header declares, against the limits, before anything is allocated.
void checkSize(std::int64_t w, std::int64_t h, const ImageLimits& lim, const std::string& name) {
    if (w <= 0 || h <= 0) throw SetupError(FileLoc{name}, "bad image size");
    if (lim.width > 0 && (w != lim.width || h != lim.height)) {
        throw SetupError(FileLoc{name}, "image is " + std::to_string(w) + "x" + std::to_string(h) +
                                            ", expected " + std::to_string(lim.width) + "x" +
                                            std::to_string(lim.height));
    }
    if (w > lim.maxWidth || h > lim.maxHeight) {
        throw SetupError(FileLoc{name}, "image is " + std::to_string(w) + "x" + std::to_string(h) +
                                            ", larger than the limit of " +
                                            std::to_string(lim.maxWidth) + "x" +
                                            std::to_string(lim.maxHeight));
    }
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
            checkSize(std::int64_t{i32(8)} - i32(0) + 1, std::int64_t{i32(12)} - i32(4) + 1, limits,
                      name);
            window = true;
        }
        at += size;
    }
    if (!window) bad("no dataWindow");
}

}  // namespace

ImageF parsePfm(std::string_view bytes, const std::string& name, const ImageLimits& limits) {
    HeaderReader hr(bytes, name);
    const std::string_view magic = hr.token();
    if (magic != "Pf" && magic != "PF") {
        hr.bad("not a PFM file (magic '" + std::string(magic.substr(0, 8)) + "')");
    }
    const int channels = magic == "PF" ? 3 : 1;
    const int w = hr.positive("width");
    const int h = hr.positive("height");
    const double scale = hr.real("scale");
    if (scale == 0.0) hr.bad("bad scale '0'");
    checkSize(w, h, limits, name);
    const std::string_view raw =
        hr.samples(static_cast<std::uint64_t>(w) * static_cast<std::uint64_t>(h) * channels * 4);
    const bool little = scale < 0.0;
    ImageF img(w, h);
    for (int y = 0; y < h; ++y) {
        // PFM stores rows bottom to top.
        float* dst = img.row(h - 1 - y);
        for (int x = 0; x < w; ++x) {
            const auto* b = reinterpret_cast<const unsigned char*>(
                &raw[(static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + x) * channels *
                     4]);
            std::uint32_t u =
                little
                    ? (b[0] | (b[1] << 8) | (b[2] << 16) | (static_cast<std::uint32_t>(b[3]) << 24))
                    : (b[3] | (b[2] << 8) | (b[1] << 16) |
                       (static_cast<std::uint32_t>(b[0]) << 24));
            float f = 0.0f;
            std::memcpy(&f, &u, 4);
            dst[x] = f;
        }
    }
    return img;
}

ImageU16 parsePgm(std::string_view bytes, const std::string& name, const ImageLimits& limits) {
    HeaderReader hr(bytes, name);
    if (hr.token() != "P5") hr.bad("not a binary PGM");
    const int w = hr.positive("width");
    const int h = hr.positive("height");
    const int maxv = hr.positive("maximum value");
    if (maxv > 65535) hr.bad("bad maximum value " + std::to_string(maxv));
    checkSize(w, h, limits, name);
    const int bpp = maxv > 255 ? 2 : 1;
    const std::string_view raw =
        hr.samples(static_cast<std::uint64_t>(w) * static_cast<std::uint64_t>(h) * bpp);
    ImageU16 img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t i = (static_cast<std::size_t>(y) * w + x) * bpp;
            const auto hi = static_cast<unsigned char>(raw[i]);
            img(x, y) = static_cast<std::uint16_t>(
                bpp == 2 ? (hi << 8) | static_cast<unsigned char>(raw[i + 1]) : hi);
        }
    return img;
}

RadianceFile parseExr(std::string_view bytes, const std::string& name, const ImageLimits& limits) {
    RadianceFile r;
    checkExrHeader(bytes, name, limits);
    try {
        MemoryIStream stream(name, bytes);
        Imf::InputFile file(stream);
        const Imf::Header& hdr = file.header();
        const Imath::Box2i dw = hdr.dataWindow();
        // In 64 bits: the corners are any 32-bit integers.
        const std::int64_t w = std::int64_t{dw.max.x} - dw.min.x + 1;
        const std::int64_t h = std::int64_t{dw.max.y} - dw.min.y + 1;
        checkSize(w, h, limits, name);
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
        if (const auto* a = hdr.findTypedAttribute<Imf::StringAttribute>("nvstim.unit")) {
            r.unit = a->value();
        }
        if (const auto* a = hdr.findTypedAttribute<Imf::StringAttribute>("nvstim.spectrum")) {
            r.spectrum = a->value();
        }
    } catch (const SetupError&) {
        throw;
    } catch (const std::exception& e) {
        fail(name, std::string("cannot read EXR: ") + e.what());
    }
    return r;
}

RadianceFile readRadiance(const std::filesystem::path& path, const ImageLimits& limits) {
    const std::string ext = lower(path.extension().string());
    if (ext != ".exr" && ext != ".pfm") fail(path, "input must be .exr or .pfm");
    const std::string bytes = readInputFile(path, kMaxImageFileBytes, "image file");
    if (ext == ".exr") return parseExr(bytes, path.string(), limits);
    RadianceFile r;
    r.image = parsePfm(bytes, path.string(), limits);
    return r;
}

namespace {

// An Imf::OStream on a file descriptor that keeps its first error: ~OutputFile writes the line
// offset table and swallows any exception (ImfOutputFile.cpp), so a failure there would
// otherwise go unnoticed and leave a truncated file that looks written.
class CheckedFdStream final : public Imf::OStream {
  public:
    CheckedFdStream(const char* name, int fd) : Imf::OStream(name), fd_(fd) {}
    void write(const char c[], int n) override {
        while (n > 0 && error_ == 0) {
            const ssize_t k = ::write(fd_, c, static_cast<std::size_t>(n));
            if (k < 0 && errno == EINTR) continue;
            if (k <= 0) {
                error_ = k < 0 ? errno : EIO;
                break;
            }
            c += k;
            n -= static_cast<int>(k);
            pos_ += static_cast<std::uint64_t>(k);
        }
        if (error_ != 0) throw std::runtime_error(std::strerror(error_));
    }
    std::uint64_t tellp() override { return pos_; }
    void seekp(std::uint64_t pos) override {
        if (::lseek(fd_, static_cast<off_t>(pos), SEEK_SET) < 0) {
            if (error_ == 0) error_ = errno;
            throw std::runtime_error(std::strerror(error_));
        }
        pos_ = pos;
    }
    int error() const { return error_; }

  private:
    int fd_;
    std::uint64_t pos_ = 0;
    int error_ = 0;
};

// Flushes, syncs and closes a stdio file, then reports the first failure of all three.
void closeChecked(const std::filesystem::path& path, std::FILE* fp) {
    int err = 0;
    if (std::fflush(fp) != 0 || std::ferror(fp) != 0) err = errno != 0 ? errno : EIO;
    if (err == 0 && ::fsync(fileno(fp)) != 0) err = errno;
    if (std::fclose(fp) != 0 && err == 0) err = errno;
    if (err != 0) fail(path, std::string("write failed: ") + std::strerror(err));
}

}  // namespace

void writeExr(const std::filesystem::path& path, ImageView<const float> img,
              const std::string& unit, const std::string& spectrum) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) fail(path, std::string("cannot create: ") + std::strerror(errno));
    std::string error;
    CheckedFdStream stream(path.c_str(), fd);
    try {
        Imf::Header hdr(img.width(), img.height());
        hdr.channels().insert("Y", Imf::Channel(Imf::FLOAT));
        if (!unit.empty()) hdr.insert("nvstim.unit", Imf::StringAttribute(unit));
        if (!spectrum.empty()) hdr.insert("nvstim.spectrum", Imf::StringAttribute(spectrum));
        Imf::OutputFile file(stream, hdr);
        Imf::FrameBuffer fb;
        fb.insert(
            "Y",
            Imf::Slice(Imf::FLOAT, const_cast<char*>(reinterpret_cast<const char*>(img.row(0))),
                       sizeof(float), sizeof(float) * static_cast<std::size_t>(img.stride_px())));
        file.setFrameBuffer(fb);
        file.writePixels(img.height());
    } catch (const std::exception& e) {
        error = e.what();
    }
    // ~OutputFile has run: the stream knows whether the offsets reached the file.
    if (error.empty() && stream.error() != 0) error = std::strerror(stream.error());
    if (error.empty() && ::fsync(fd) != 0) error = std::strerror(errno);
    if (::close(fd) != 0 && error.empty()) error = std::strerror(errno);
    if (!error.empty()) fail(path, "cannot write EXR: " + error);
}

void writePfm(const std::filesystem::path& path, ImageView<const float> img) {
    std::ofstream out(path, std::ios::binary);
    if (!out) fail(path, "cannot create");
    out << "Pf\n" << img.width() << " " << img.height() << "\n-1.0\n";
    for (int y = img.height() - 1; y >= 0; --y)
        out.write(reinterpret_cast<const char*>(img.row(y)),
                  static_cast<std::streamsize>(sizeof(float)) * img.width());
    out.close();  // a failed flush or close sets failbit
    if (!out) fail(path, "write failed");
}

void writePgm(const std::filesystem::path& path, ImageView<const std::uint16_t> img, int maxValue) {
    std::ofstream out(path, std::ios::binary);
    if (!out) fail(path, "cannot create");
    out << "P5\n" << img.width() << " " << img.height() << "\n" << maxValue << "\n";
    std::vector<unsigned char> row(static_cast<std::size_t>(img.width()) * 2);
    const bool wide = maxValue > 255;
    for (int y = 0; y < img.height(); ++y) {
        const std::uint16_t* s = img.row(y);
        std::size_t n = 0;
        for (int x = 0; x < img.width(); ++x) {
            if (wide) row[n++] = static_cast<unsigned char>(s[x] >> 8);  // big-endian
            row[n++] = static_cast<unsigned char>(s[x] & 0xff);
        }
        out.write(reinterpret_cast<const char*>(row.data()), static_cast<std::streamsize>(n));
    }
    out.close();  // a failed flush or close sets failbit
    if (!out) fail(path, "write failed");
}

ImageU16 readPgm(const std::filesystem::path& path, const ImageLimits& limits) {
    return parsePgm(readInputFile(path, kMaxImageFileBytes, "image file"), path.string(), limits);
}

void writePng(const std::filesystem::path& path, ImageView<const std::uint16_t> img, int maxValue) {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> fp(std::fopen(path.c_str(), "wb"),
                                                       &std::fclose);
    if (!fp) fail(path, "cannot create");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        fail(path, "libpng: out of memory");
    }
    const bool wide = maxValue > 255;
    std::vector<unsigned char> row(static_cast<std::size_t>(img.width()) * 2);
    // libpng reports errors by longjmp; nothing with a destructor lives between here and
    // the calls below except `row` and `fp`, which outlive the jump target.
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        fail(path, "libpng: write failed");
    }
    png_init_io(png, fp.get());
    png_set_IHDR(png, info, static_cast<png_uint_32>(img.width()),
                 static_cast<png_uint_32>(img.height()), wide ? 16 : 8, PNG_COLOR_TYPE_GRAY,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < img.height(); ++y) {
        const std::uint16_t* s = img.row(y);
        std::size_t n = 0;
        for (int x = 0; x < img.width(); ++x) {
            if (wide) row[n++] = static_cast<unsigned char>(s[x] >> 8);
            row[n++] = static_cast<unsigned char>(s[x] & 0xff);
        }
        png_write_row(png, row.data());
    }
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    // libpng buffers through stdio: the bytes are on disk only after a checked flush and close.
    closeChecked(path, fp.release());
}

bool hasFramePattern(const std::string& pattern) {
    return pattern.find("{frame") != std::string::npos;
}

std::string expandFramePattern(const std::string& pattern, long long frame) {
    // "{frame}" or "{frame:Nd}" / "{frame:0Nd}" with N of at most two digits (width ≤ 20, the
    // digits of a 64-bit number): the first well-formed field is expanded, the rest of the
    // name kept as is. Scanned by hand: no regex, no std::stoi to throw on a long number.
    constexpr std::string_view kOpen = "{frame";
    for (std::size_t at = pattern.find(kOpen); at != std::string::npos;
         at = pattern.find(kOpen, at + 1)) {
        std::size_t i = at + kOpen.size();
        int width = 0;
        if (i < pattern.size() && pattern[i] == ':') {
            ++i;
            if (i < pattern.size() && pattern[i] == '0') ++i;
            const std::size_t digits = i;
            while (i < pattern.size() && i - digits < 3 && pattern[i] >= '0' && pattern[i] <= '9')
                width = width * 10 + (pattern[i++] - '0');
            if (i == digits || i - digits > 2 || i >= pattern.size() || pattern[i] != 'd') continue;
            ++i;
        }
        if (i >= pattern.size() || pattern[i] != '}' || width > 20) continue;
        char buf[32];
        std::snprintf(buf, sizeof buf, "%0*lld", width, frame);
        return pattern.substr(0, at) + buf + pattern.substr(i + 1);
    }
    return pattern;
}

}  // namespace nvs::sensor
