// png_check FILE.png WIDTH HEIGHT [--colour RRGGBB:MIN]...: exits 0 when FILE.png is a
// WIDTH x HEIGHT image that shows something: many distinct colours, and no single colour
// covering nearly all of it. Used by the snapshot tests to tell a rendered workbench from a
// blank or garbled frame. Each --colour asks for at least MIN pixels of exactly that colour
// (e.g. the fill of the correlation heat map's diagonal cells: the view shows a fit).
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <unordered_map>
#include <vector>

#include <stb_image.h>  // the implementation is in libstb

namespace {

constexpr int kMinColours = 24;             // text antialiasing alone gives dozens
constexpr double kMaxDominantShare = 0.95;  // the background may not be all there is

}  // namespace

int main(int argc, char** argv) {
  struct Wanted {
    unsigned colour;
    long min;
  };
  std::vector<Wanted> wanted;
  bool usage_ok = argc >= 4 && (argc - 4) % 2 == 0;
  for (int i = 4; usage_ok && i + 1 < argc; i += 2) {
    unsigned colour = 0;
    long min = 0;
    usage_ok = std::strcmp(argv[i], "--colour") == 0 &&
               std::sscanf(argv[i + 1], "%6x:%ld", &colour, &min) == 2;
    wanted.push_back({colour, min});
  }
  if (!usage_ok) {
    std::fprintf(stderr, "usage: png_check FILE.png WIDTH HEIGHT [--colour RRGGBB:MIN]...\n");
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
  for (const Wanted& w : wanted) {
    const auto it = counts.find(w.colour);
    const long n = it == counts.end() ? 0 : it->second;
    std::printf("png_check: colour %06x: %ld pixels (at least %ld wanted)\n", w.colour, n, w.min);
    if (n < w.min) {
      std::fprintf(stderr, "png_check: too few pixels of colour %06x\n", w.colour);
      return 1;
    }
  }
  return 0;
}
