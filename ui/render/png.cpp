#include "ui/render/png.h"

#include <cstddef>
#include <string>
#include <vector>

#include <stb_image_write.h>  // the implementation is in libstb: no STB_IMAGE_WRITE_IMPLEMENTATION

#include "core/util/file.h"

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
  // Encoded in memory, then written atomically like every other file (a snapshot that fails
  // half-way never leaves a truncated PNG in place of the previous one).
  std::string png;
  auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data),
                                               static_cast<std::size_t>(size));
  };
  if (!stbi_write_png_to_func(append, &png, width, height, 3, rgb.data(), width * 3)) {
    *error = path + ": cannot encode the PNG image";
    return false;
  }
  if (auto st = WriteFileAtomic(path, png); !st) {
    *error = st.error().ToString();
    return false;
  }
  return true;
}

}  // namespace gb::ui
