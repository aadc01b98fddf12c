#pragma once
// RGB images: PNG files (libpng), contact sheets and short labels.
#include <cstdint>
#include <string_view>
#include <vector>

namespace goo::render {

/// 8-bit RGB, rows from the top.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  ///< width × height × 3

  Image() = default;
  Image(int w, int h, std::uint8_t grey = 255);
  [[nodiscard]] std::uint8_t* at(int x, int y) { return rgb.data() + 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)); }
  [[nodiscard]] const std::uint8_t* at(int x, int y) const {
    return rgb.data() + 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x));
  }
};

/// The image as a PNG file's bytes (written to disk by the caller: io's
/// atomic writer).
std::vector<std::uint8_t> encode_png(const Image& image);
/// An 8-bit RGB or RGBA PNG's bytes (alpha dropped) as an image; goo::Error
/// naming `name` when they are not one.
Image decode_png(const std::vector<std::uint8_t>& bytes, std::string_view name);

/// Copies `tile` into `sheet` with its top-left corner at (x, y), clipped.
void paste(Image& sheet, const Image& tile, int x, int y);

/// Writes `text` (digits, letters, space and . , : = - / ( ) %) in a 5×7
/// pixel font scaled by `scale`, top-left at (x, y), in `colour`; clipped.
/// Unknown characters are drawn as a box. Returns the width drawn.
int draw_text(Image& image, std::string_view text, int x, int y, int scale, const std::uint8_t (&colour)[3]);
/// The width `draw_text` would draw.
int text_width(std::string_view text, int scale);

}  // namespace goo::render
