#include "sim/sensor/image_io.h"

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
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <regex>
#include <stdexcept>
#include <vector>

#include "sim/core/error.h"

namespace nvs::sensor {

namespace {

[[noreturn]] void fail(const std::filesystem::path& p, const std::string& msg) {
    throw SetupError(FileLoc{p.string(), 0, 0}, msg);
}

std::string lower(std::string s) {
    for (char& ch : s)
        ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return s;
}

// Next whitespace-separated token of a PNM header, skipping '#' comments.
std::string pnmToken(std::istream& in) {
    std::string t;
    int ch = in.get();
    for (;;) {
        while (ch != EOF && std::isspace(ch))
            ch = in.get();
        if (ch == '#') {
            while (ch != EOF && ch != '\n')
                ch = in.get();
            continue;
        }
        break;
    }
    while (ch != EOF && !std::isspace(ch)) {
        t.push_back(static_cast<char>(ch));
        ch = in.get();
    }
    return t;  // the single whitespace after the token has been consumed
}

int toInt(const std::filesystem::path& p, const std::string& t) {
    try {
        std::size_t used = 0;
        const int v = std::stoi(t, &used);
        if (used != t.size()) fail(p, "bad header value '" + t + "'");
        return v;
    } catch (const std::logic_error&) {
        fail(p, "bad header value '" + t + "'");
    }
}

ImageF readPfm(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    if (!in) fail(p, "cannot open");
    const std::string magic = pnmToken(in);
    if (magic != "Pf" && magic != "PF") fail(p, "not a PFM file (magic '" + magic + "')");
    const int channels = magic == "PF" ? 3 : 1;
    const int w = toInt(p, pnmToken(in));
    const int h = toInt(p, pnmToken(in));
    const std::string scaleTok = pnmToken(in);
    double scale = 0.0;
    try {
        scale = std::stod(scaleTok);
    } catch (const std::logic_error&) {
        fail(p, "bad scale '" + scaleTok + "'");
    }
    if (w <= 0 || h <= 0 || w > 65536 || h > 65536) fail(p, "bad size");
    const bool little = scale < 0.0;
    std::vector<unsigned char> raw(static_cast<std::size_t>(w) * h * channels * 4);
    in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size()));
    if (in.gcount() != static_cast<std::streamsize>(raw.size())) fail(p, "truncated data");
    ImageF img(w, h);
    for (int y = 0; y < h; ++y) {
        // PFM stores rows bottom to top.
        float* dst = img.row(h - 1 - y);
        for (int x = 0; x < w; ++x) {
            const unsigned char* b = &raw[(static_cast<std::size_t>(y) * w + x) * channels * 4];
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

RadianceFile readExr(const std::filesystem::path& p) {
    RadianceFile r;
    try {
        Imf::InputFile file(p.c_str());
        const Imf::Header& hdr = file.header();
        const Imath::Box2i dw = hdr.dataWindow();
        const int w = dw.max.x - dw.min.x + 1;
        const int h = dw.max.y - dw.min.y + 1;
        std::string channel;
        for (const char* c : {"Y", "R", "L"}) {
            if (hdr.channels().findChannel(c)) {
                channel = c;
                break;
            }
        }
        if (channel.empty()) {
            auto it = hdr.channels().begin();
            if (it == hdr.channels().end()) fail(p, "EXR has no channels");
            channel = it.name();
        }
        r.image = ImageF(w, h);
        Imf::FrameBuffer fb;
        char* base = reinterpret_cast<char*>(r.image.row(0)) -
                     (static_cast<std::ptrdiff_t>(dw.min.y) * r.image.stride_px() + dw.min.x) *
                         static_cast<std::ptrdiff_t>(sizeof(float));
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
        fail(p, std::string("cannot read EXR: ") + e.what());
    }
    return r;
}

}  // namespace

RadianceFile readRadiance(const std::filesystem::path& path) {
    if (!std::filesystem::exists(path)) fail(path, "no such file");
    const std::string ext = lower(path.extension().string());
    if (ext == ".exr") return readExr(path);
    if (ext == ".pfm") {
        RadianceFile r;
        r.image = readPfm(path);
        return r;
    }
    fail(path, "input must be .exr or .pfm");
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

ImageU16 readPgm(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(path, "cannot open");
    if (pnmToken(in) != "P5") fail(path, "not a binary PGM");
    const int w = toInt(path, pnmToken(in));
    const int h = toInt(path, pnmToken(in));
    const int maxv = toInt(path, pnmToken(in));
    if (w <= 0 || h <= 0 || maxv <= 0 || maxv > 65535) fail(path, "bad header");
    const int bpp = maxv > 255 ? 2 : 1;
    std::vector<unsigned char> raw(static_cast<std::size_t>(w) * h * bpp);
    in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size()));
    if (in.gcount() != static_cast<std::streamsize>(raw.size())) fail(path, "truncated");
    ImageU16 img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t i = (static_cast<std::size_t>(y) * w + x) * bpp;
            img(x, y) = static_cast<std::uint16_t>(bpp == 2 ? (raw[i] << 8) | raw[i + 1] : raw[i]);
        }
    return img;
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
    static const std::regex re(R"(\{frame(?::0?(\d+)d)?\})");
    std::smatch m;
    if (!std::regex_search(pattern, m, re)) return pattern;
    int width = m[1].matched ? std::stoi(m[1].str()) : 0;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%0*lld", width, frame);
    return m.prefix().str() + buf + m.suffix().str();
}

}  // namespace nvs::sensor
