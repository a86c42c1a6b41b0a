#include "sim/io/pnm.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "sim/core/error.h"
#include "sim/core/input_file.h"

namespace nvs::io {

namespace {

// A PNM/PFM header read from memory: magic, then whitespace-separated decimal fields, '#'
// comments, and exactly one whitespace byte before the samples. Each field is bounded: at
// most 32 characters, integers of at most 9 digits.
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
    checkImageSize(w, h, limits, name);
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

ImageU16 parsePgm(std::string_view bytes, const std::string& name, const ImageLimits& limits,
                  int* maxValue) {
    HeaderReader hr(bytes, name);
    if (hr.token() != "P5") hr.bad("not a binary PGM");
    const int w = hr.positive("width");
    const int h = hr.positive("height");
    const int maxv = hr.positive("maximum value");
    if (maxv > 65535) hr.bad("bad maximum value " + std::to_string(maxv));
    checkImageSize(w, h, limits, name);
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
    if (maxValue != nullptr) *maxValue = maxv;
    return img;
}

ImageU16 readPgm(const std::filesystem::path& path, const ImageLimits& limits) {
    return parsePgm(readInputFile(path, kMaxImageFileBytes, "image file"), path.string(), limits);
}

namespace {

constexpr std::size_t kPgmHeaderMax = 40;  // "P5\n" + two ints + a 5-digit maxval + newlines

std::size_t pgmHeader(int width, int height, int maxValue, char* out) noexcept {
    const int n = std::snprintf(out, kPgmHeaderMax, "P5\n%d %d\n%d\n", width, height, maxValue);
    return n > 0 ? static_cast<std::size_t>(n) : 0;
}

}  // namespace

std::size_t pgmFileBytes(int width, int height, int maxValue) noexcept {
    char header[kPgmHeaderMax];
    return pgmHeader(width, height, maxValue, header) + static_cast<std::size_t>(width) *
                                                            static_cast<std::size_t>(height) *
                                                            (maxValue > 255 ? 2 : 1);
}

std::size_t encodePgm(ImageView<const std::uint16_t> img, int maxValue,
                      unsigned char* out) noexcept {
    char header[kPgmHeaderMax];
    const std::size_t n = pgmHeader(img.width(), img.height(), maxValue, header);
    std::memcpy(out, header, n);
    unsigned char* dst = out + n;
    const int w = img.width();
    for (int y = 0; y < img.height(); ++y) {
        const std::uint16_t* s = img.row(y);
        if (maxValue > 255) {
            for (int x = 0; x < w; ++x) {
                *dst++ = static_cast<unsigned char>(s[x] >> 8);  // big-endian
                *dst++ = static_cast<unsigned char>(s[x] & 0xff);
            }
        } else {
            for (int x = 0; x < w; ++x)
                *dst++ = static_cast<unsigned char>(s[x] & 0xff);
        }
    }
    return static_cast<std::size_t>(dst - out);
}

void writePgm(const std::filesystem::path& path, ImageView<const std::uint16_t> img, int maxValue) {
    std::vector<unsigned char> bytes(pgmFileBytes(img.width(), img.height(), maxValue));
    const std::size_t n = encodePgm(img, maxValue, bytes.data());
    FileOut out(path);
    out.write(bytes.data(), n);
    out.close();
}

void writePfm(const std::filesystem::path& path, ImageView<const float> img) {
    char header[48];
    const int n =
        std::snprintf(header, sizeof header, "Pf\n%d %d\n-1.0\n", img.width(), img.height());
    std::vector<unsigned char> row(static_cast<std::size_t>(img.width()) * 4);
    FileOut out(path);
    out.write(header, static_cast<std::size_t>(n));
    for (int y = img.height() - 1; y >= 0; --y) {  // bottom to top
        const float* s = img.row(y);
        for (int x = 0; x < img.width(); ++x) {
            std::uint32_t u = 0;
            std::memcpy(&u, &s[x], 4);
            for (int k = 0; k < 4; ++k)  // little-endian, whatever the host
                row[static_cast<std::size_t>(x) * 4 + static_cast<std::size_t>(k)] =
                    static_cast<unsigned char>(u >> (8 * k));
        }
        out.write(row.data(), row.size());
    }
    out.close();
}

}  // namespace nvs::io
