// png_check FILE.png WIDTH HEIGHT: exits 0 when FILE.png is a WIDTH x HEIGHT image that shows
// something: many distinct colours, and no single colour covering nearly all of it. Used by the
// snapshot tests to tell a rendered workbench from a blank or garbled frame.
#include <stb_image.h>  // the implementation is in libstb

#include <cstdio>
#include <cstdlib>
#include <unordered_map>

namespace {

constexpr int kMinColours = 24;             // text antialiasing alone gives dozens
constexpr double kMaxDominantShare = 0.95;  // the background may not be all there is

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: png_check FILE.png WIDTH HEIGHT\n");
    return 2;
  }
  const int want_w = std::atoi(argv[2]);
  const int want_h = std::atoi(argv[3]);
  int w = 0, h = 0, channels = 0;
  unsigned char* pixels = stbi_load(argv[1], &w, &h, &channels, 4);
  if (!pixels) {
    std::fprintf(stderr, "png_check: %s: not a readable image (%s)\n", argv[1],
                 stbi_failure_reason());
    return 1;
  }
  std::unordered_map<unsigned, long> counts;
  for (long i = 0; i < static_cast<long>(w) * h; ++i) {
    const unsigned char* p = pixels + 4 * i;
    ++counts[(unsigned{p[0]} << 16) | (unsigned{p[1]} << 8) | p[2]];
  }
  stbi_image_free(pixels);
  long dominant = 0;
  for (const auto& [colour, n] : counts) dominant = n > dominant ? n : dominant;
  const double share = static_cast<double>(dominant) / (static_cast<double>(w) * h);
  std::printf("png_check: %s: %dx%d, %zu colours, most common colour covers %.1f%%\n", argv[1], w,
              h, counts.size(), 100.0 * share);
  if (w != want_w || h != want_h) {
    std::fprintf(stderr, "png_check: expected %dx%d\n", want_w, want_h);
    return 1;
  }
  if (static_cast<int>(counts.size()) < kMinColours || share > kMaxDominantShare) {
    std::fprintf(stderr, "png_check: the image looks blank\n");
    return 1;
  }
  return 0;
}
