// greybench: the workbench in a GLFW window (user guide §6).
//   greybench [PROJECT.json] [--width W --height H] [--screenshot OUT.png [--frames N]
//             [--view-image WxH]]
// Without a project it opens the bundled case study. --screenshot draws N frames once the
// project has loaded, writes the window's pixels to OUT.png and exits (for scripts under Xvfb);
// with --view-image, the picture File › Export › Image of the view draws instead (the view at
// W x H, offscreen, whatever the window's size).
// The framebuffer functions of OpenGL 3 (libGL exports them; the window's context is 3.3 core).
#define GL_GLEXT_PROTOTYPES
#include <algorithm>
#include <cfloat>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include "core/util/json.h"
#include "core/util/sanitizers.h"
#if GREYBENCH_ASAN
#include <sanitizer/lsan_interface.h>
#endif

#include "ui/export/export.h"
#include "ui/render/png.h"
#include "ui/shell/shell.h"
#include "ui/state/app_state.h"
#include "ui/theme.h"
#include "ui/workbench.h"

#ifndef GREYBENCH_ASSETS_DIR
#error "GREYBENCH_ASSETS_DIR must name the assets directory (app/CMakeLists.txt sets it)"
#endif

// The shell's shortcuts name GLFW key codes without including GLFW.
static_assert(gb::ui::kKeyF5 == GLFW_KEY_F5 && gb::ui::kKeyF1 == GLFW_KEY_F1 &&
              gb::ui::kKeyEqual == GLFW_KEY_EQUAL && gb::ui::kKeyMinus == GLFW_KEY_MINUS &&
              GLFW_KEY_O == 'O' && GLFW_KEY_1 == '1');

namespace {

constexpr int kExitBadInput = 2;
constexpr int kExitFailed = 1;
constexpr int kDefaultWidth = 1440;
constexpr int kDefaultHeight = 900;
// Idle: wait this long for input before drawing again; after input, draw this many frames
// without waiting so ImGui settles (popups opening, hover states).
constexpr double kIdleWaitSeconds = 0.5;
constexpr int kFramesAfterInput = 3;

struct Options {
  std::string project;
  std::string screenshot;
  int frames = 3;
  int image_w = 0, image_h = 0;  // --view-image WxH
  int width = kDefaultWidth;
  int height = kDefaultHeight;
};

constexpr const char* kUsage =
    "usage: greybench [PROJECT.json] [--width W --height H] [--screenshot OUT.png [--frames N]\n"
    "                 [--view-image WxH]]\n";

int Fail(int status, const std::string& message) {
  std::fprintf(stderr, "greybench: error: %s\n", message.c_str());
  return status;
}

bool ParseInt(const char* text, int lo, int hi, int* out) {
  char* end = nullptr;
  const long v = std::strtol(text, &end, 10);
  if (*text == '\0' || *end != '\0' || v < lo || v > hi) return false;
  *out = static_cast<int>(v);
  return true;
}

// Returns an error message, or "" when the command line is good.
std::string ParseArgs(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--help" || arg == "-h") return "help";
    if (arg.substr(0, 2) != "--") {
      if (!o->project.empty()) return "more than one project given";
      o->project = argv[i];
      continue;
    }
    if (i + 1 >= argc) return std::string(arg) + " needs a value";
    const char* value = argv[++i];
    if (arg == "--screenshot") {
      o->screenshot = value;
    } else if (arg == "--frames") {
      if (!ParseInt(value, 1, 100000, &o->frames)) return "--frames: expected a count >= 1";
    } else if (arg == "--width") {
      if (!ParseInt(value, 64, 16384, &o->width)) return "--width: expected pixels";
    } else if (arg == "--height") {
      if (!ParseInt(value, 64, 16384, &o->height)) return "--height: expected pixels";
    } else if (arg == "--view-image") {
      const std::string v = value;
      const auto x = v.find('x');
      if (x == std::string::npos || !ParseInt(v.substr(0, x).c_str(), 64, 16384, &o->image_w) ||
          !ParseInt(v.substr(x + 1).c_str(), 64, 16384, &o->image_h))
        return "--view-image: expected WxH in pixels (1024x768)";
    } else {
      return "unknown option '" + std::string(arg) + "'";
    }
  }
  return "";
}

void GlfwError(int code, const char* description) {
  std::fprintf(stderr, "greybench: GLFW error %d: %s\n", code, description);
}

// An OpenGL 3.3 core context (GLSL 330); failing that, whatever the driver gives (GLSL 130).
GLFWwindow* OpenWindow(const Options& o, const char** glsl_version) {
  glfwWindowHint(GLFW_SCALE_TO_MONITOR, GLFW_TRUE);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  *glsl_version = "#version 330 core";
  if (GLFWwindow* w = glfwCreateWindow(o.width, o.height, "greybench", nullptr, nullptr)) return w;
  glfwDefaultWindowHints();
  glfwWindowHint(GLFW_SCALE_TO_MONITOR, GLFW_TRUE);
  *glsl_version = "#version 130";
  return glfwCreateWindow(o.width, o.height, "greybench", nullptr, nullptr);
}

bool WriteScreenshot(GLFWwindow* window, const std::string& path) {
  int w = 0, h = 0;
  glfwGetFramebufferSize(window, &w, &h);
  std::vector<unsigned char> pixels(static_cast<std::size_t>(w) * h * 4);
  glReadBuffer(GL_BACK);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, pixels.data());
  std::string error;
  if (!gb::ui::WritePngFromGl(path, w, h, pixels.data(), &error)) {
    std::fprintf(stderr, "greybench: error: %s\n", error.c_str());
    return false;
  }
  return true;
}

// Draws an ImGui frame of its own (`draw`) at width x height pixels into an offscreen
// framebuffer and reads it back (RGBA, rows from the bottom); empty when no framebuffer could be
// made. Runs after the window's frame was rendered; the window's back buffer is not touched.
// `frames` frames are drawn and the last one kept (a view drawn twice forgets the window's last
// hover, which plots sharing a time axis show for a frame).
template <class Draw>
std::vector<unsigned char> DrawOffscreen(int width, int height, const ImVec4& clear, Draw draw,
                                         int frames = 1) {
  GLuint texture = 0, framebuffer = 0;
  glGenTextures(1, &texture);
  glBindTexture(GL_TEXTURE_2D, texture);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, width, height, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  glBindTexture(GL_TEXTURE_2D, 0);
  glGenFramebuffers(1, &framebuffer);
  glBindFramebuffer(GL_FRAMEBUFFER, framebuffer);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture, 0);
  std::vector<unsigned char> rgba;
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE) {
    ImGuiIO& io = ImGui::GetIO();
    const ImVec2 display = io.DisplaySize, scale = io.DisplayFramebufferScale;
    const ImVec2 mouse = io.MousePos;
    io.DisplaySize = ImVec2(static_cast<float>(width), static_cast<float>(height));
    io.DisplayFramebufferScale = ImVec2(1.0f, 1.0f);
    io.MousePos = ImVec2(-FLT_MAX, -FLT_MAX);  // no crosshair, no tooltip, nothing hovered
    for (int f = 0; f < frames; ++f) {
      ImGui::NewFrame();
      draw();
      ImGui::Render();
    }
    glViewport(0, 0, width, height);
    glClearColor(clear.x, clear.y, clear.z, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    rgba.resize(static_cast<std::size_t>(width) * height * 4);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
    io.DisplaySize = display;
    io.DisplayFramebufferScale = scale;
    io.MousePos = mouse;
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glDeleteFramebuffers(1, &framebuffer);
  glDeleteTextures(1, &texture);
  return rgba;
}

// A plot's "Save image as PNG": the plot alone at the PNG's size (ui/export/export.h).
void DrawPngOffscreen(gb::ui::AppState& state, const gb::ui::PendingPng& png) {
  const std::vector<unsigned char> rgba =
      DrawOffscreen(png.width, png.height, ImVec4(1, 1, 1, 1),
                    [&] { gb::ui::plot::DrawFigureFrame(state.plots, png.figure); });
  gb::ui::FinishPendingPng(state, png, rgba.empty() ? nullptr : &rgba);
}

// File › Export › Image of the view: the workbench drawn whole at the image's size, one frame
// (the mouse and keys of this frame were the window's; a frame draws nothing they would repeat).
void DrawViewImageOffscreen(gb::ui::AppState& state, const gb::ui::PendingViewImage& image) {
  const std::vector<unsigned char> rgba = DrawOffscreen(
      image.width, image.height, ImGui::GetStyle().Colors[ImGuiCol_WindowBg],
      [&] { gb::ui::DrawWorkbench(state); }, 2);
  gb::ui::FinishPendingViewImage(state, image, rgba.empty() ? nullptr : &rgba);
}

int Run(GLFWwindow* window, const char* glsl_version, const Options& options) {
  namespace ui = gb::ui;
  // The monitor's content scale (its DPI over 96), within limits; read again every frame, so a
  // window moved to a monitor of another DPI gets its fonts and style rebuilt for it.
  auto content_scale = [window] {
    float xscale = 1.0f, yscale = 1.0f;
    glfwGetWindowContentScale(window, &xscale, &yscale);
    return std::clamp(std::max(xscale, yscale), 1.0f, 4.0f);
  };
  float scale = content_scale();

  ui::AppState state;
  ui::SetUpWorkbench(state, scale);
  ImGui_ImplGlfw_InitForOpenGL(window, true);
  ImGui_ImplOpenGL3_Init(glsl_version);
  if (options.screenshot.empty()) ui::StartSession(state);  // scripted screenshots touch no files

  if (!options.project.empty()) {
    ui::OpenProject(state, options.project);
  } else {
    const std::string bundled = GREYBENCH_ASSETS_DIR "/projects/case_study.json";
    if (std::filesystem::exists(bundled)) {
      ui::OpenProject(state, bundled);
    } else {
      state.start_note = "The bundled case study (" + bundled + ") is not there yet.";
      ui::AddMessage(state, ui::Severity::kInfo, state.start_note);
    }
  }

  int status = 0;
  int frames_drawn_loaded = 0;  // frames drawn with no job under way (for --screenshot)
  int busy_frames = kFramesAfterInput;
  std::string title;
  float zoom = 1.0f;
  ui::ThemeKind theme = ui::ThemeKind::kLight;  // what SetUpWorkbench applied above
  while (!state.quit_requested) {
    // Closing the window is File > Quit: it asks to save changes first.
    if (glfwWindowShouldClose(window)) {
      glfwSetWindowShouldClose(window, GLFW_FALSE);
      ui::RequestQuit(state);
      if (state.quit_requested) break;
      busy_frames = kFramesAfterInput;
    }
    // A job under way redraws every frame: its progress shows, and its result is installed
    // (and a cancel acknowledged) at the next frame.
    const bool busy = busy_frames > 0 || ui::AnyJobActive(state) || !options.screenshot.empty() ||
                      ImGui::IsAnyMouseDown();
    if (busy) {
      glfwPollEvents();
      busy_frames = std::max(0, busy_frames - 1);
    } else {
      const double t0 = glfwGetTime();
      glfwWaitEventsTimeout(kIdleWaitSeconds);
      if (glfwGetTime() - t0 < 0.9 * kIdleWaitSeconds) busy_frames = kFramesAfterInput;
    }

    // View > Zoom, or another monitor's DPI: fonts and style rebuilt at the new scale.
    // And the node editor's zoom: its text gets a font baked for it (within limits).
    if (const float now = content_scale();
        state.shell.zoom != zoom || now != scale || state.shell.theme != theme ||
        state.fonts.wanted_canvas_zoom != state.fonts.canvas_zoom) {
      zoom = state.shell.zoom;
      theme = state.shell.theme;
      scale = now;
      ImGui::GetIO().Fonts->Clear();
      ui::SetUpWorkbench(state, scale * zoom);
      ImGui_ImplOpenGL3_DestroyFontsTexture();
      ImGui_ImplOpenGL3_CreateFontsTexture();
    }
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    ui::DrawWorkbench(state);
    ImGui::Render();

    if (const std::string t = ui::WindowTitle(state); t != title) {
      title = t;
      glfwSetWindowTitle(window, title.c_str());
    }
    int fb_w = 0, fb_h = 0;
    glfwGetFramebufferSize(window, &fb_w, &fb_h);
    glViewport(0, 0, fb_w, fb_h);
    const ImVec4 bg = ImGui::GetStyle().Colors[ImGuiCol_WindowBg];
    glClearColor(bg.x, bg.y, bg.z, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    // A plot's "Save image as PNG": the plot alone, drawn offscreen (ui/export/export.h).
    if (const std::optional<ui::PendingPng> png = ui::TakePendingPng(state)) {
      DrawPngOffscreen(state, *png);
    }
    if (const std::optional<ui::PendingViewImage> image = ui::TakePendingViewImage(state)) {
      DrawViewImageOffscreen(state, *image);
    }

    if (!options.screenshot.empty() && !state.load_job.active() &&
        ++frames_drawn_loaded >= options.frames) {
      if (options.image_w > 0) {
        const ui::PendingViewImage image{options.image_w, options.image_h, options.screenshot};
        DrawViewImageOffscreen(state, image);
        const bool written =
            !state.messages.empty() && state.messages.back().severity == ui::Severity::kInfo &&
            state.messages.back().text.find(options.screenshot) != std::string::npos;
        if (!written && !state.messages.empty())
          std::fprintf(stderr, "greybench: error: %s\n", state.messages.back().text.c_str());
        status = written ? 0 : kExitFailed;
      } else {
        status = WriteScreenshot(window, options.screenshot) ? 0 : kExitFailed;
      }
      break;
    }
    glfwSwapBuffers(window);
  }

  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  const std::string arg_error = ParseArgs(argc, argv, &options);
  if (arg_error == "help") {
    std::fputs(kUsage, stdout);
    return 0;
  }
  if (!arg_error.empty()) {
    std::fputs(kUsage, stderr);
    return Fail(kExitBadInput, arg_error);
  }

  glfwSetErrorCallback(GlfwError);
  if (!glfwInit()) return Fail(kExitFailed, "cannot initialise GLFW (is there a display?)");
  const char* glsl_version = nullptr;
  GLFWwindow* window = OpenWindow(options, &glsl_version);
  if (!window) {
    glfwTerminate();
    return Fail(kExitFailed, "cannot create a window with an OpenGL 3 context");
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(1);

  ImGui::CreateContext();
  const int status = Run(window, glsl_version, options);
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
#if GREYBENCH_ASAN
  // scripts/sanitize.sh: glfwTerminate closes the display and Mesa unloads its driver, after
  // which the leak check at exit could not name the library of the driver's own leaks (to
  // suppress them, tests/sanitize/lsan.supp). Everything of ours is freed by now: check here.
  __lsan_do_leak_check();
#endif
  glfwTerminate();
  return status;
}
