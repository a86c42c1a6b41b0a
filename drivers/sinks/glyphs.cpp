#include "drivers/sinks/glyphs.h"

#include <cstddef>
#include <cstring>

namespace nvs::drivers {

namespace {

// Each glyph: five rows of three bits, the high bit the leftmost pixel.
struct Glyph {
    char c;
    unsigned char rows[kGlyphHeight_px];
};

constexpr Glyph kGlyphs[] = {
    {'0', {0b111, 0b101, 0b101, 0b101, 0b111}}, {'1', {0b010, 0b110, 0b010, 0b010, 0b111}},
    {'2', {0b111, 0b001, 0b111, 0b100, 0b111}}, {'3', {0b111, 0b001, 0b111, 0b001, 0b111}},
    {'4', {0b101, 0b101, 0b111, 0b001, 0b001}}, {'5', {0b111, 0b100, 0b111, 0b001, 0b111}},
    {'6', {0b111, 0b100, 0b111, 0b101, 0b111}}, {'7', {0b111, 0b001, 0b010, 0b010, 0b010}},
    {'8', {0b111, 0b101, 0b111, 0b101, 0b111}}, {'9', {0b111, 0b101, 0b111, 0b001, 0b111}},
    {'.', {0b000, 0b000, 0b000, 0b000, 0b010}}, {':', {0b000, 0b010, 0b000, 0b010, 0b000}},
    {'-', {0b000, 0b000, 0b111, 0b000, 0b000}}, {'s', {0b000, 0b111, 0b100, 0b001, 0b111}},
};

const Glyph* glyphOf(char c) noexcept {
    for (const Glyph& g : kGlyphs)
        if (g.c == c) return &g;
    return nullptr;  // a space, or a character without a glyph
}

}  // namespace

int textWidth_px(const char* text, int scale) noexcept {
    const int n = static_cast<int>(std::strlen(text));
    return n == 0 ? 0 : (n * kGlyphAdvance_px - 1) * scale;
}

void drawText(std::uint16_t* img, int stride, int height, int x, int y, int clipX, const char* text,
              int scale, std::uint16_t value) noexcept {
    for (int i = 0; text[i] != '\0'; ++i) {
        const Glyph* g = glyphOf(text[i]);
        const int gx = x + i * kGlyphAdvance_px * scale;
        if (g == nullptr) continue;
        for (int r = 0; r < kGlyphHeight_px; ++r) {
            for (int c = 0; c < kGlyphWidth_px; ++c) {
                if ((g->rows[r] >> (kGlyphWidth_px - 1 - c) & 1) == 0) continue;
                for (int dy = 0; dy < scale; ++dy) {
                    const int py = y + r * scale + dy;
                    if (py < 0 || py >= height) continue;
                    for (int dx = 0; dx < scale; ++dx) {
                        const int px = gx + c * scale + dx;
                        if (px < 0 || px >= clipX) continue;
                        img[static_cast<std::size_t>(py) * static_cast<std::size_t>(stride) +
                            static_cast<std::size_t>(px)] = value;
                    }
                }
            }
        }
    }
}

}  // namespace nvs::drivers
