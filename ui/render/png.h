// Writing a rendered frame to a PNG file (stb_image_write from the Debian package libstb).
#pragma once

#include <string>

namespace gb::ui {

// Writes `width` x `height` RGBA pixels to `path` as an opaque RGB PNG. The rows are read
// bottom-up (as glReadPixels and OSMesa deliver them) and written top-down. The same pixels
// always give the same bytes. On failure returns false and says why in `error`.
bool WritePngFromGl(const std::string& path, int width, int height, const unsigned char* rgba,
                    std::string* error);

}  // namespace gb::ui
