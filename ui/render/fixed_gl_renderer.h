// Renders ImGui draw data with OpenGL 1.1 (fixed function, client-side vertex arrays).
//
// Used by greybench-snapshot on OSMesa. Unlike ImGui's OpenGL2 backend it honours
// ImDrawCmd::VtxOffset (and says so in io.BackendFlags), so one window's draw list may hold
// more than 65536 vertices, as the stacked plots of a long dataset do with 16-bit indices.
// Needs a current GL context for every call; links against whatever provides gl* (libOSMesa).
#pragma once

#include <imgui.h>

namespace gb::ui {

class FixedGlRenderer {
 public:
  FixedGlRenderer() = default;
  FixedGlRenderer(const FixedGlRenderer&) = delete;
  FixedGlRenderer& operator=(const FixedGlRenderer&) = delete;
  ~FixedGlRenderer();

  // Registers with ImGui's io and uploads the font atlas (call after the fonts are added).
  void Init();
  void Render(const ImDrawData* draw_data);

 private:
  unsigned int font_texture_ = 0;
};

}  // namespace gb::ui
