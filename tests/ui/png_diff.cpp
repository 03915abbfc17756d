// png_diff ACTUAL.png GOLDEN.png [--diff OUT.png]: compares a rendered view with its golden
// image. Exit 0 when they match within the tolerance below, 1 when they do not (or an image is
// unreadable or of another size), 2 on a bad command line.
//
// Tolerance (documented in screenshots/README.md): a pixel differs when any of its channels
// differs by more than kChannelTolerance; the images match when at most kMaxDifferingShare of
// the pixels differ. The snapshot is deterministic on one machine (fixed frame time, no clock,
// software rasteriser), so the tolerance only absorbs rasteriser rounding on anti-aliased edges
// between Mesa builds; a moved widget, a changed plot or a changed line of text exceeds it.
//
// --diff writes an image of the differences: the golden dimmed to a fifth, the differing pixels
// in red, so a failing test shows where to look.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <stb_image.h>  // the implementations are in libstb
#include <stb_image_write.h>

namespace {

constexpr int kChannelTolerance = 16;        // of 255
constexpr double kMaxDifferingShare = 5e-4;  // 0.05 % of the pixels: 512 at 1280 x 800

struct Image {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
};

bool Load(const char* path, Image* image) {
  int channels = 0;
  unsigned char* pixels = stbi_load(path, &image->w, &image->h, &channels, 3);
  if (!pixels) {
    std::fprintf(stderr, "png_diff: %s: not a readable image (%s)\n", path, stbi_failure_reason());
    return false;
  }
  image->rgb.assign(pixels, pixels + static_cast<std::size_t>(image->w) * image->h * 3);
  stbi_image_free(pixels);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  const char* diff_path = nullptr;
  if (argc == 5 && std::strcmp(argv[3], "--diff") == 0) {
    diff_path = argv[4];
  } else if (argc != 3) {
    std::fprintf(stderr, "usage: png_diff ACTUAL.png GOLDEN.png [--diff OUT.png]\n");
    return 2;
  }
  Image actual, golden;
  if (!Load(argv[1], &actual) || !Load(argv[2], &golden)) return 1;
  if (actual.w != golden.w || actual.h != golden.h) {
    std::fprintf(stderr, "png_diff: %s is %dx%d, the golden %s is %dx%d\n", argv[1], actual.w,
                 actual.h, argv[2], golden.w, golden.h);
    return 1;
  }
  const std::size_t n = static_cast<std::size_t>(actual.w) * actual.h;
  std::size_t differing = 0;
  int largest = 0;
  std::vector<unsigned char> diff(n * 3);
  for (std::size_t i = 0; i < n; ++i) {
    int d = 0;
    for (int c = 0; c < 3; ++c)
      d = std::max(d, std::abs(actual.rgb[3 * i + c] - golden.rgb[3 * i + c]));
    largest = std::max(largest, d);
    const bool differs = d > kChannelTolerance;
    differing += differs;
    for (int c = 0; c < 3; ++c) {
      diff[3 * i + c] =
          differs ? (c == 0 ? 255 : 0) : static_cast<unsigned char>(golden.rgb[3 * i + c] / 5);
    }
  }
  const double share = static_cast<double>(differing) / static_cast<double>(n);
  std::printf(
      "png_diff: %s vs %s: %zu of %zu pixels differ (%.4f %%, tolerance %.4f %%), "
      "largest channel difference %d\n",
      argv[1], argv[2], differing, n, 100.0 * share, 100.0 * kMaxDifferingShare, largest);
  if (share <= kMaxDifferingShare) return 0;
  if (diff_path) {
    if (stbi_write_png(diff_path, actual.w, actual.h, 3, diff.data(), actual.w * 3)) {
      std::fprintf(stderr, "png_diff: the differences are drawn in %s\n", diff_path);
    } else {
      std::fprintf(stderr, "png_diff: %s: cannot write the difference image\n", diff_path);
    }
  }
  return 1;
}
