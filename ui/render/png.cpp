#include "ui/render/png.h"

#include <stb_image_write.h>  // the implementation is in libstb: no STB_IMAGE_WRITE_IMPLEMENTATION

#include <cstddef>
#include <vector>

namespace gb::ui {

bool WritePngFromGl(const std::string& path, int width, int height, const unsigned char* rgba,
                    std::string* error) {
  if (width <= 0 || height <= 0) {
    *error = "empty image";
    return false;
  }
  const auto w = static_cast<std::size_t>(width);
  const auto h = static_cast<std::size_t>(height);
  std::vector<unsigned char> rgb(w * h * 3);
  for (std::size_t y = 0; y < h; ++y) {
    const unsigned char* src = rgba + (h - 1 - y) * w * 4;
    unsigned char* dst = rgb.data() + y * w * 3;
    for (std::size_t x = 0; x < w; ++x) {
      dst[3 * x + 0] = src[4 * x + 0];
      dst[3 * x + 1] = src[4 * x + 1];
      dst[3 * x + 2] = src[4 * x + 2];
    }
  }
  if (!stbi_write_png(path.c_str(), width, height, 3, rgb.data(), width * 3)) {
    *error = path + ": cannot write the PNG file";
    return false;
  }
  return true;
}

}  // namespace gb::ui
