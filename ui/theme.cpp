#include "ui/theme.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

namespace gb::ui {
namespace {

// Latin, Greek (σ, ω, θ, Δ), punctuation (– — … ·), super/subscripts, arrows, mathematical
// operators (∈ ≈ √ ∫) and geometric shapes (● ▸): what equations and units need.
constexpr ImWchar kGlyphRanges[] = {
    0x0020, 0x00FF, 0x0370, 0x03FF, 0x2000, 0x206F, 0x2070, 0x209F,
    0x2190, 0x21FF, 0x2200, 0x22FF, 0x25A0, 0x25FF, 0,
};

ImFont* AddFont(const char* file, float size, std::string* missing) {
  const std::string path = std::string(kFontDir) + file;
  if (!std::filesystem::exists(path)) {
    if (missing->empty()) *missing = path;
    return nullptr;
  }
  ImFontConfig config;
  config.OversampleH = 3;
  config.OversampleV = 1;
  return ImGui::GetIO().Fonts->AddFontFromFileTTF(path.c_str(), size, &config, kGlyphRanges);
}

}  // namespace

float CanvasZoomFor(float editor_zoom) {
  if (!(editor_zoom > 1.0f)) return 1.0f;
  return std::min(kMaxCanvasZoom, std::ceil(editor_zoom * 2.0f) / 2.0f);
}

namespace {

void LoadFonts(AppState& state, float scale) {
  ImGuiIO& io = ImGui::GetIO();
  const float size = std::round(kBaseFontSize * scale);
  std::string missing;
  Fonts& f = state.fonts;
  f.scale = scale;
  f.regular = AddFont("DejaVuSans.ttf", size, &missing);
  f.bold = AddFont("DejaVuSans-Bold.ttf", size, &missing);
  f.heading = AddFont("DejaVuSans-Bold.ttf", std::round(size * 1.27f), &missing);
  f.mono = AddFont("DejaVuSansMono.ttf", size, &missing);
  f.canvas = nullptr;
  f.canvas_zoom = 1.0f;
  if (f.wanted_canvas_zoom > 1.0f) {
    f.canvas_zoom = std::min(f.wanted_canvas_zoom, kMaxCanvasZoom);
    f.canvas = AddFont("DejaVuSans.ttf", std::round(size * f.canvas_zoom), &missing);
  }
  if (!f.regular) {
    ImFontConfig config;
    config.SizePixels = std::round(13.0f * scale);
    f.regular = io.Fonts->AddFontDefault(&config);
  }
  io.FontDefault = f.regular;
  if (!f.bold) f.bold = f.regular;
  if (!f.heading) f.heading = f.bold;
  if (!f.mono) f.mono = f.regular;
  if (!missing.empty()) {
    AddMessage(state, Severity::kWarning,
               "Font " + missing + " is missing (install fonts-dejavu-core); using a fallback.");
  }
}

ImVec4 Rgb(int r, int g, int b, float a = 1.0f) {
  return ImVec4(r / 255.0f, g / 255.0f, b / 255.0f, a);
}

void ApplyStyle(float scale) {
  ImGuiStyle& s = ImGui::GetStyle();
  s = ImGuiStyle();
  ImGui::StyleColorsLight(&s);
  s.WindowPadding = ImVec2(12, 10);
  s.FramePadding = ImVec2(7, 4);
  s.CellPadding = ImVec2(8, 3);
  s.ItemSpacing = ImVec2(8, 6);
  s.ItemInnerSpacing = ImVec2(6, 4);
  s.IndentSpacing = 16;
  s.ScrollbarSize = 12;
  s.GrabMinSize = 10;
  s.WindowBorderSize = 0;
  s.ChildBorderSize = 1;
  s.PopupBorderSize = 1;
  // Fields are white like popups, tables and plot areas: a border shows where to type.
  s.FrameBorderSize = 1;
  s.TabBorderSize = 0;
  s.WindowRounding = 0;
  s.ChildRounding = 0;
  s.FrameRounding = 3;
  s.PopupRounding = 3;
  s.ScrollbarRounding = 6;
  s.GrabRounding = 3;
  s.TabRounding = 3;
  s.SelectableTextAlign = ImVec2(0.0f, 0.5f);

  ImVec4* c = s.Colors;
  const ImVec4 text = Rgb(33, 37, 43);
  const ImVec4 accent = Rgb(47, 111, 219);
  c[ImGuiCol_Text] = text;
  c[ImGuiCol_TextDisabled] = Rgb(128, 134, 144);
  c[ImGuiCol_WindowBg] = Rgb(250, 250, 251);
  c[ImGuiCol_ChildBg] = Rgb(0, 0, 0, 0.0f);
  c[ImGuiCol_PopupBg] = Rgb(255, 255, 255);
  c[ImGuiCol_Border] = Rgb(218, 221, 226);
  c[ImGuiCol_BorderShadow] = Rgb(0, 0, 0, 0.0f);
  c[ImGuiCol_FrameBg] = Rgb(255, 255, 255);
  c[ImGuiCol_FrameBgHovered] = Rgb(240, 244, 251);
  c[ImGuiCol_FrameBgActive] = Rgb(229, 237, 250);
  c[ImGuiCol_TitleBg] = Rgb(238, 240, 243);
  c[ImGuiCol_TitleBgActive] = Rgb(229, 232, 237);
  c[ImGuiCol_MenuBarBg] = Rgb(238, 240, 243);
  c[ImGuiCol_ScrollbarBg] = Rgb(0, 0, 0, 0.0f);
  c[ImGuiCol_ScrollbarGrab] = Rgb(196, 200, 207);
  c[ImGuiCol_ScrollbarGrabHovered] = Rgb(170, 175, 184);
  c[ImGuiCol_ScrollbarGrabActive] = Rgb(150, 156, 166);
  c[ImGuiCol_CheckMark] = accent;
  c[ImGuiCol_Button] = Rgb(232, 235, 240);
  c[ImGuiCol_ButtonHovered] = Rgb(218, 228, 246);
  c[ImGuiCol_ButtonActive] = Rgb(198, 214, 242);
  c[ImGuiCol_Header] = Rgb(222, 232, 250);
  c[ImGuiCol_HeaderHovered] = Rgb(233, 239, 250);
  c[ImGuiCol_HeaderActive] = Rgb(210, 224, 248);
  c[ImGuiCol_Separator] = Rgb(218, 221, 226);
  c[ImGuiCol_Tab] = Rgb(232, 235, 240);
  c[ImGuiCol_TabHovered] = Rgb(214, 226, 248);
  c[ImGuiCol_TabActive] = Rgb(205, 220, 247);
  c[ImGuiCol_TableHeaderBg] = Rgb(241, 243, 246);
  c[ImGuiCol_TableBorderStrong] = Rgb(214, 218, 224);
  c[ImGuiCol_TableBorderLight] = Rgb(230, 233, 237);
  c[ImGuiCol_TableRowBg] = Rgb(255, 255, 255, 0.0f);
  c[ImGuiCol_TableRowBgAlt] = Rgb(243, 245, 248, 0.7f);
  c[ImGuiCol_TextSelectedBg] = Rgb(47, 111, 219, 0.25f);
  c[ImGuiCol_ModalWindowDimBg] = Rgb(30, 34, 40, 0.25f);

  s.ScaleAllSizes(scale);
}

}  // namespace

void SetUpWorkbench(AppState& state, float scale) {
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;  // the layout is fixed; nothing to remember in imgui.ini
  io.LogFilename = nullptr;
  LoadFonts(state, scale);
  ApplyStyle(scale);
  plot::PlotStyle& ps = state.plots.style;
  ps = plot::PlotStyle();
  ps.scale = scale;
  ps.title_font = state.fonts.bold;
}

}  // namespace gb::ui
