#pragma once
// Images: a pixel type (float radiance and counts, uint16 and uint8 video), width, height and a
// row stride in pixels. Image<T> owns its pixels; ImageView<T> borrows them (a V4L2 buffer, a
// region of another image). Rows are padded to 64 bytes so row starts are SIMD-aligned.

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>

namespace nvs {

template <typename T>
class ImageView {
  public:
    ImageView() = default;
    ImageView(T* data, int width, int height, std::ptrdiff_t stride_px)
        : data_(data), width_(width), height_(height), stride_(stride_px) {}

    int width() const { return width_; }
    int height() const { return height_; }
    std::ptrdiff_t stride_px() const { return stride_; }
    bool empty() const { return width_ == 0 || height_ == 0; }

    T* row(int y) const {
        assert(y >= 0 && y < height_);
        return data_ + y * stride_;
    }
    T& operator()(int x, int y) const {
        assert(x >= 0 && x < width_);
        return row(y)[x];
    }
    // A sub-rectangle sharing these pixels.
    ImageView region(int x, int y, int w, int h) const {
        assert(x >= 0 && y >= 0 && x + w <= width_ && y + h <= height_);
        return ImageView(data_ + y * stride_ + x, w, h, stride_);
    }
    void fill(T value) const {
        for (int y = 0; y < height_; ++y) {
            T* r = row(y);
            for (int x = 0; x < width_; ++x)
                r[x] = value;
        }
    }
    // Copies the pixels of a view of the same size into this one (no allocation).
    void copyFrom(ImageView<const std::remove_const_t<T>> src) const {
        assert(src.width() == width_ && src.height() == height_);
        for (int y = 0; y < height_; ++y)
            std::copy(src.row(y), src.row(y) + width_, row(y));
    }

  private:
    T* data_ = nullptr;
    int width_ = 0;
    int height_ = 0;
    std::ptrdiff_t stride_ = 0;
};

template <typename T>
class Image {
  public:
    static constexpr std::size_t kRowAlign_bytes = 64;

    Image() = default;
    // Allocates (setup phase only); pixels are zero.
    Image(int width, int height) : width_(width), height_(height) {
        assert(width >= 0 && height >= 0);
        const std::size_t perAlign = kRowAlign_bytes / sizeof(T);
        stride_ = static_cast<std::ptrdiff_t>((static_cast<std::size_t>(width) + perAlign - 1) /
                                              perAlign * perAlign);
        const std::size_t n = static_cast<std::size_t>(stride_) * static_cast<std::size_t>(height);
        data_.reset(n == 0 ? nullptr
                           : static_cast<T*>(::operator new[](n * sizeof(T),
                                                              std::align_val_t(kRowAlign_bytes))));
        for (std::size_t i = 0; i < n; ++i)
            data_[i] = T{};
    }
    Image(const Image& o) : Image(o.width_, o.height_) { copyFrom(o.view()); }
    Image& operator=(const Image& o) {
        if (this != &o) {
            Image tmp(o);
            *this = std::move(tmp);
        }
        return *this;
    }
    Image(Image&&) noexcept = default;
    Image& operator=(Image&&) noexcept = default;

    int width() const { return width_; }
    int height() const { return height_; }
    std::ptrdiff_t stride_px() const { return stride_; }
    bool empty() const { return width_ == 0 || height_ == 0; }

    T* row(int y) { return view().row(y); }
    const T* row(int y) const { return cview().row(y); }
    T& operator()(int x, int y) { return view()(x, y); }
    const T& operator()(int x, int y) const { return cview()(x, y); }
    void fill(T value) { view().fill(value); }

    ImageView<T> view() { return ImageView<T>(data_.get(), width_, height_, stride_); }
    ImageView<const T> view() const { return cview(); }
    ImageView<const T> cview() const {
        return ImageView<const T>(data_.get(), width_, height_, stride_);
    }

    // Copies pixels from a view of the same size (no allocation).
    void copyFrom(ImageView<const T> src) { view().copyFrom(src); }

  private:
    struct AlignedDelete {
        void operator()(T* p) const { ::operator delete[](p, std::align_val_t(kRowAlign_bytes)); }
    };
    std::unique_ptr<T[], AlignedDelete> data_;
    int width_ = 0;
    int height_ = 0;
    std::ptrdiff_t stride_ = 0;
};

using ImageF = Image<float>;
using ImageU16 = Image<std::uint16_t>;
using ImageU8 = Image<std::uint8_t>;

// Quantises float pixels to an integer type: round(v·scale + offset), clamped to [0, max_T].
// No allocation; dst must have src's size.
template <typename Dst>
void quantize(ImageView<const float> src, ImageView<Dst> dst, float scale, float offset) {
    assert(src.width() == dst.width() && src.height() == dst.height());
    constexpr float kMax = static_cast<float>(static_cast<Dst>(~Dst{0}));
    for (int y = 0; y < src.height(); ++y) {
        const float* s = src.row(y);
        Dst* d = dst.row(y);
        for (int x = 0; x < src.width(); ++x) {
            float v = s[x] * scale + offset + 0.5f;
            v = v < 0.0f ? 0.0f : (v > kMax ? kMax : v);
            d[x] = static_cast<Dst>(v);
        }
    }
}

}  // namespace nvs
