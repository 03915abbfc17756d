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

// The light theme's colours, then the dark and high-contrast ones as changes to it.
void LightColors(ImVec4* c);
void DarkColors(ImVec4* c);
void ProjectorColors(ImVec4* c);

void ApplyStyle(float scale, ThemeKind theme) {
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

  switch (theme) {
    case ThemeKind::kLight:
      LightColors(s.Colors);
      break;
    case ThemeKind::kDark:
      DarkColors(s.Colors);
      break;
    case ThemeKind::kProjector:
      ProjectorColors(s.Colors);
      s.FrameBorderSize = 1.5f;
      s.ChildBorderSize = 1.5f;
      break;
  }
  s.ScaleAllSizes(scale);
}

void LightColors(ImVec4* c) {
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
}

void DarkColors(ImVec4* c) {
  const ImVec4 accent = Rgb(88, 148, 240);
  c[ImGuiCol_Text] = Rgb(226, 229, 234);
  c[ImGuiCol_TextDisabled] = Rgb(146, 152, 162);
  c[ImGuiCol_WindowBg] = Rgb(32, 34, 38);
  c[ImGuiCol_ChildBg] = Rgb(0, 0, 0, 0.0f);
  c[ImGuiCol_PopupBg] = Rgb(40, 43, 48);
  c[ImGuiCol_Border] = Rgb(66, 70, 78);
  c[ImGuiCol_BorderShadow] = Rgb(0, 0, 0, 0.0f);
  c[ImGuiCol_FrameBg] = Rgb(22, 24, 27);
  c[ImGuiCol_FrameBgHovered] = Rgb(44, 52, 66);
  c[ImGuiCol_FrameBgActive] = Rgb(50, 62, 84);
  c[ImGuiCol_TitleBg] = Rgb(40, 43, 48);
  c[ImGuiCol_TitleBgActive] = Rgb(46, 50, 56);
  c[ImGuiCol_MenuBarBg] = Rgb(40, 43, 48);
  c[ImGuiCol_ScrollbarBg] = Rgb(0, 0, 0, 0.0f);
  c[ImGuiCol_ScrollbarGrab] = Rgb(78, 83, 92);
  c[ImGuiCol_ScrollbarGrabHovered] = Rgb(98, 104, 114);
  c[ImGuiCol_ScrollbarGrabActive] = Rgb(118, 124, 134);
  c[ImGuiCol_CheckMark] = accent;
  c[ImGuiCol_SliderGrab] = accent;
  c[ImGuiCol_SliderGrabActive] = Rgb(120, 170, 245);
  c[ImGuiCol_Button] = Rgb(52, 56, 63);
  c[ImGuiCol_ButtonHovered] = Rgb(60, 76, 104);
  c[ImGuiCol_ButtonActive] = Rgb(68, 90, 130);
  c[ImGuiCol_Header] = Rgb(50, 66, 96);
  c[ImGuiCol_HeaderHovered] = Rgb(56, 72, 100);
  c[ImGuiCol_HeaderActive] = Rgb(62, 82, 118);
  c[ImGuiCol_Separator] = Rgb(66, 70, 78);
  c[ImGuiCol_Tab] = Rgb(46, 50, 56);
  c[ImGuiCol_TabHovered] = Rgb(60, 76, 104);
  c[ImGuiCol_TabActive] = Rgb(56, 72, 100);
  c[ImGuiCol_TableHeaderBg] = Rgb(42, 45, 50);
  c[ImGuiCol_TableBorderStrong] = Rgb(66, 70, 78);
  c[ImGuiCol_TableBorderLight] = Rgb(52, 56, 62);
  c[ImGuiCol_TableRowBg] = Rgb(0, 0, 0, 0.0f);
  c[ImGuiCol_TableRowBgAlt] = Rgb(255, 255, 255, 0.04f);
  c[ImGuiCol_TextSelectedBg] = Rgb(88, 148, 240, 0.35f);
  c[ImGuiCol_ModalWindowDimBg] = Rgb(0, 0, 0, 0.45f);
  c[ImGuiCol_PlotHistogram] = accent;
}

// For a projector: the light theme with black text, darker grey text and rules, and stronger
// selection, so that nothing is lost to a washed-out beamer.
void ProjectorColors(ImVec4* c) {
  LightColors(c);
  c[ImGuiCol_Text] = Rgb(0, 0, 0);
  c[ImGuiCol_TextDisabled] = Rgb(70, 74, 80);
  c[ImGuiCol_WindowBg] = Rgb(255, 255, 255);
  c[ImGuiCol_Border] = Rgb(110, 116, 124);
  c[ImGuiCol_Separator] = Rgb(110, 116, 124);
  c[ImGuiCol_Button] = Rgb(214, 219, 227);
  c[ImGuiCol_Header] = Rgb(190, 210, 245);
  c[ImGuiCol_TableBorderStrong] = Rgb(110, 116, 124);
  c[ImGuiCol_TableBorderLight] = Rgb(160, 165, 172);
  c[ImGuiCol_TableRowBgAlt] = Rgb(232, 236, 242, 1.0f);
  c[ImGuiCol_CheckMark] = Rgb(20, 70, 180);
}

void ApplyPlotStyle(plot::PlotStyle* ps, ThemeKind theme) {
  switch (theme) {
    case ThemeKind::kLight:
      break;
    case ThemeKind::kDark:
      ps->plot_bg = IM_COL32(22, 24, 27, 255);
      ps->border = IM_COL32(78, 83, 92, 255);
      ps->grid = IM_COL32(48, 52, 58, 255);
      ps->tick_text = IM_COL32(176, 182, 192, 255);
      ps->title_text = IM_COL32(230, 233, 238, 255);
      ps->crosshair = IM_COL32(170, 176, 186, 150);
      ps->label_bg = IM_COL32(22, 24, 27, 220);
      ps->ink = IM_COL32(196, 200, 208, 255);
      ps->strong_ink = IM_COL32(236, 238, 242, 255);
      break;
    case ThemeKind::kProjector:
      ps->line_weight = 2.5f;
      ps->marker_radius = 3.5f;
      ps->border = IM_COL32(90, 96, 104, 255);
      ps->grid = IM_COL32(205, 209, 215, 255);
      ps->tick_text = IM_COL32(0, 0, 0, 255);
      ps->title_text = IM_COL32(0, 0, 0, 255);
      break;
  }
}

}  // namespace

void SetUpWorkbench(AppState& state, float scale) {
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;  // the layout is fixed; nothing to remember in imgui.ini
  io.LogFilename = nullptr;
  LoadFonts(state, scale);
  ApplyStyle(scale, state.shell.theme);
  plot::PlotStyle& ps = state.plots.style;
  ps = plot::PlotStyle();
  ApplyPlotStyle(&ps, state.shell.theme);
  ps.scale = scale;
  ps.title_font = state.fonts.bold;
}

namespace {

// Each theme's names and the colours the frame and the panels draw themselves, in kThemes' order.
struct ThemeInfo {
  ThemeKind kind;
  const char* name;
  const char* title;
  ThemeColors colors;  // sidebar, side panel, card, pane
};
constexpr ThemeInfo kThemeInfo[] = {
    {ThemeKind::kLight,
     "light",
     "Light",
     {IM_COL32(242, 243, 246, 255), IM_COL32(247, 248, 250, 255), IM_COL32(255, 255, 255, 255),
      IM_COL32(250, 250, 251, 255)}},
    {ThemeKind::kDark,
     "dark",
     "Dark",
     {IM_COL32(40, 43, 48, 255), IM_COL32(38, 41, 46, 255), IM_COL32(44, 47, 53, 255),
      IM_COL32(28, 30, 34, 255)}},
    {ThemeKind::kProjector,
     "projector",
     "High contrast (projector)",
     {IM_COL32(232, 235, 240, 255), IM_COL32(240, 242, 246, 255), IM_COL32(255, 255, 255, 255),
      IM_COL32(255, 255, 255, 255)}},
};

const ThemeInfo& Info(ThemeKind theme) {
  for (const ThemeInfo& t : kThemeInfo)
    if (t.kind == theme) return t;
  return kThemeInfo[0];
}

}  // namespace

const ThemeColors& Colors(ThemeKind theme) { return Info(theme).colors; }
const char* ThemeTitle(ThemeKind theme) { return Info(theme).title; }
const char* ThemeName(ThemeKind theme) { return Info(theme).name; }

std::optional<ThemeKind> ParseTheme(std::string_view name) {
  for (ThemeKind t : kThemes)
    if (name == ThemeName(t)) return t;
  return std::nullopt;
}

}  // namespace gb::ui
