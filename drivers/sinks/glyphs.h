#pragma once
// A tiny bitmap font for the contact sheet's tile labels (frame number and time): the digits,
// '.', ':', '-', 's' and the space, each 3 × 5 pixels, drawn at an integer scale into a plain
// 8-bit grey buffer. Built in because no Debian library draws text into such a buffer without a
// font stack (FreeType, fontconfig and a font file): a dozen glyphs do not justify one.
// No allocation, no throw: the sink draws in its write().

#include <cstdint>

namespace nvs::drivers {

inline constexpr int kGlyphWidth_px = 3;
inline constexpr int kGlyphHeight_px = 5;
inline constexpr int kGlyphAdvance_px = kGlyphWidth_px + 1;  // one column between glyphs

// The width `text` takes at `scale` (kGlyphAdvance_px · scale per character, the last one's
// gap left out).
int textWidth_px(const char* text, int scale) noexcept;

// Draws `text` with its top-left corner at (x, y) of `img` (width × height samples, `stride`
// per row), each glyph pixel a scale × scale square of `value`. Characters without a glyph
// are drawn as a space; what falls outside [0, clipX) × [0, height) is not drawn.
void drawText(std::uint16_t* img, int stride, int height, int x, int y, int clipX, const char* text,
              int scale, std::uint16_t value) noexcept;

}  // namespace nvs::drivers
