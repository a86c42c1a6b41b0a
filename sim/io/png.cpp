#include "sim/io/png.h"

#include <png.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include "sim/core/error.h"

namespace nvs::io {

namespace {

[[noreturn]] void fail(const std::string& name, const std::string& msg) {
    throw SetupError(FileLoc{name, 0, 0}, msg);
}

// Where libpng's output goes: a descriptor, its first error kept (libpng buffers nothing here:
// every chunk is written as it is made).
struct PngSink {
    int fd;
    int rc = 0;
};

void pngWriteFd(png_structp png, png_bytep data, png_size_t n) {
    auto* sink = static_cast<PngSink*>(png_get_io_ptr(png));
    if (sink->rc == 0) sink->rc = writeAll(sink->fd, data, n);
    if (sink->rc != 0) png_error(png, "write failed");
}

void pngFlushNone(png_structp) {}

// libpng's errors and warnings kept for the one-line error instead of printed on stderr.
void pngError(png_structp png, png_const_charp message) {
    auto* text = static_cast<std::string*>(png_get_error_ptr(png));
    if (text != nullptr) *text = message;
    png_longjmp(png, 1);
}

void pngWarning(png_structp, png_const_charp) {}

// libpng reading from the file's bytes in memory (never from the file by name: the file was
// read once, bounded, and checked to be a regular file).
struct PngBytes {
    const unsigned char* p;
    std::size_t left;
};

void readPngBytes(png_structp png, png_bytep out, png_size_t n) {
    auto* src = static_cast<PngBytes*>(png_get_io_ptr(png));
    if (n > src->left) png_error(png, "truncated PNG");
    std::memcpy(out, src->p, n);
    src->p += n;
    src->left -= n;
}

// Largest inflation a PNG's zlib stream can give (deflate's limit is about 1032:1): a header
// that promises more samples than that from the file's size is refused before any allocation.
constexpr std::uint64_t kMaxPngInflation = 1100;

// The chunks libpng's simplified API (png_image_write_*) adds for a greyscale sRGB image.
void setSrgbChunks(png_structp png, png_infop info, bool wide) {
    if (wide) {
        png_set_gAMA_fixed(png, info, PNG_GAMMA_LINEAR);
        png_set_cHRM_fixed(png, info, 31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000);
    } else {
        png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    }
}

// A 16-bit greyscale PNG's samples read raw through the low-level API.
void readPng16(std::string_view bytes, const std::string& name, ImageU16& img) {
    const int width = img.width();
    const int height = img.height();
    PngBytes src{reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size()};
    std::string pngMessage;
    png_structp png =
        png_create_read_struct(PNG_LIBPNG_VER_STRING, &pngMessage, pngError, pngWarning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_read_struct(&png, &info, nullptr);
        fail(name, "cannot read");
    }
    std::vector<unsigned char> raw(static_cast<std::size_t>(width) * height * 2);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        fail(name, "PNG read failed: " + pngMessage);
    }
    png_set_read_fn(png, &src, readPngBytes);
    png_read_info(png, info);
    if (png_get_color_type(png, info) != PNG_COLOR_TYPE_GRAY ||
        png_get_bit_depth(png, info) != 16 ||
        png_get_image_width(png, info) != static_cast<png_uint_32>(width) ||
        png_get_image_height(png, info) != static_cast<png_uint_32>(height)) {
        png_destroy_read_struct(&png, &info, nullptr);
        fail(name, "16-bit frames must be greyscale PNG");
    }
    const int passes = png_set_interlace_handling(png);
    png_read_update_info(png, info);
    for (int pass = 0; pass < passes; ++pass)
        for (int y = 0; y < height; ++y)
            png_read_row(png, raw.data() + static_cast<std::size_t>(y) * width * 2, nullptr);
    png_destroy_read_struct(&png, &info, nullptr);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const std::size_t i = (static_cast<std::size_t>(y) * width + x) * 2;
            img(x, y) = static_cast<std::uint16_t>((raw[i] << 8) | raw[i + 1]);
        }
}

}  // namespace

int writePng(int fd, ImageView<const std::uint16_t> img, int bitDepth, PngColour colour) noexcept {
    PngSink sink{fd};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, pngError, pngWarning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        return -ENOMEM;
    }
    const bool wide = bitDepth > 8;
    std::vector<unsigned char> row;
    // libpng reports errors by longjmp; nothing with a destructor lives between here and the
    // calls below except `row`, which outlives the jump target.
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return sink.rc != 0 ? sink.rc : -EIO;
    }
    row.resize(static_cast<std::size_t>(img.width()) * 2);
    png_set_write_fn(png, &sink, pngWriteFd, pngFlushNone);
    png_set_IHDR(png, info, static_cast<png_uint_32>(img.width()),
                 static_cast<png_uint_32>(img.height()), wide ? 16 : 8, PNG_COLOR_TYPE_GRAY,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    if (colour == PngColour::Srgb) setSrgbChunks(png, info, wide);
    png_write_info(png, info);
    for (int y = 0; y < img.height(); ++y) {
        const std::uint16_t* s = img.row(y);
        std::size_t n = 0;
        for (int x = 0; x < img.width(); ++x) {
            if (wide) row[n++] = static_cast<unsigned char>(s[x] >> 8);  // big-endian
            row[n++] = static_cast<unsigned char>(s[x] & 0xff);
        }
        png_write_row(png, row.data());
    }
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return 0;
}

void writePng(const std::filesystem::path& path, ImageView<const std::uint16_t> img, int maxValue) {
    FileOut out(path);
    out.close(writePng(out.fd(), img, maxValue > 255 ? 16 : 8, PngColour::None),
              "libpng: write failed");
}

ImageU16 parsePng(std::string_view bytes, const std::string& name, const ImageLimits& limits,
                  int* maxValue) {
    png_image im{};
    im.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_memory(&im, bytes.data(), bytes.size()))
        fail(name, std::string("not a readable PNG: ") + im.message);
    const std::uint64_t samples = std::uint64_t{im.width} * im.height;
    if (im.width == 0 || im.height == 0 || im.width > static_cast<unsigned>(limits.maxWidth) ||
        im.height > static_cast<unsigned>(limits.maxHeight) ||
        samples > kMaxPngInflation * bytes.size()) {
        png_image_free(&im);
        fail(name, "PNG header claims " + std::to_string(im.width) + "x" +
                       std::to_string(im.height) + ", more than a " + std::to_string(bytes.size()) +
                       "-byte file can hold or above " + std::to_string(limits.maxWidth) + "x" +
                       std::to_string(limits.maxHeight));
    }
    try {
        checkImageSize(im.width, im.height, limits, name);
    } catch (...) {
        png_image_free(&im);
        throw;
    }
    const bool wide = PNG_IMAGE_SAMPLE_COMPONENT_SIZE(im.format) == 2;
    ImageU16 img(static_cast<int>(im.width), static_cast<int>(im.height));
    if (wide) {
        png_image_free(&im);
        readPng16(bytes, name, img);
        if (maxValue != nullptr) *maxValue = 65535;
        return img;
    }
    im.format = PNG_FORMAT_GRAY;
    std::vector<unsigned char> buf(PNG_IMAGE_SIZE(im));
    if (!png_image_finish_read(&im, nullptr, buf.data(), 0, nullptr))
        fail(name, std::string("PNG read failed: ") + im.message);
    for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x)
            img(x, y) = buf[static_cast<std::size_t>(y) * img.width() + x];
    if (maxValue != nullptr) *maxValue = 255;
    return img;
}

}  // namespace nvs::io
