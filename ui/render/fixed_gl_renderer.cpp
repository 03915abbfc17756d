#include "ui/render/fixed_gl_renderer.h"

#include <cstddef>
#include <cstdint>

#include <GL/gl.h>

namespace gb::ui {

FixedGlRenderer::~FixedGlRenderer() {
  if (font_texture_ == 0) return;
  const GLuint texture = font_texture_;
  glDeleteTextures(1, &texture);
  if (ImGui::GetCurrentContext()) ImGui::GetIO().Fonts->SetTexID(nullptr);
}

void FixedGlRenderer::Init() {
  ImGuiIO& io = ImGui::GetIO();
  io.BackendRendererName = "greybench_fixed_gl";
  io.BackendFlags |= ImGuiBackendFlags_RendererHasVtxOffset;

  unsigned char* pixels = nullptr;
  int width = 0, height = 0;
  io.Fonts->GetTexDataAsRGBA32(&pixels, &width, &height);
  GLuint texture = 0;
  glGenTextures(1, &texture);
  glBindTexture(GL_TEXTURE_2D, texture);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA, width, height, 0, GL_RGBA, GL_UNSIGNED_BYTE, pixels);
  font_texture_ = texture;
  io.Fonts->SetTexID(reinterpret_cast<ImTextureID>(static_cast<std::intptr_t>(texture)));
}

void FixedGlRenderer::Render(const ImDrawData* draw_data) {
  const ImVec2 scale = draw_data->FramebufferScale;
  const int fb_w = static_cast<int>(draw_data->DisplaySize.x * scale.x);
  const int fb_h = static_cast<int>(draw_data->DisplaySize.y * scale.y);
  if (fb_w <= 0 || fb_h <= 0) return;

  glViewport(0, 0, fb_w, fb_h);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glDisable(GL_CULL_FACE);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_LIGHTING);
  glDisable(GL_COLOR_MATERIAL);
  glEnable(GL_SCISSOR_TEST);
  glEnable(GL_TEXTURE_2D);
  glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
  glShadeModel(GL_SMOOTH);
  glTexEnvi(GL_TEXTURE_ENV, GL_TEXTURE_ENV_MODE, GL_MODULATE);
  glEnableClientState(GL_VERTEX_ARRAY);
  glEnableClientState(GL_TEXTURE_COORD_ARRAY);
  glEnableClientState(GL_COLOR_ARRAY);

  const ImVec2 pos = draw_data->DisplayPos;
  const ImVec2 size = draw_data->DisplaySize;
  glMatrixMode(GL_PROJECTION);
  glLoadIdentity();
  glOrtho(pos.x, pos.x + size.x, pos.y + size.y, pos.y, -1.0, 1.0);
  glMatrixMode(GL_MODELVIEW);
  glLoadIdentity();

  constexpr GLenum kIndexType = sizeof(ImDrawIdx) == 2 ? GL_UNSIGNED_SHORT : GL_UNSIGNED_INT;
  constexpr GLsizei kStride = sizeof(ImDrawVert);
  for (int n = 0; n < draw_data->CmdListsCount; ++n) {
    const ImDrawList* list = draw_data->CmdLists[n];
    const ImDrawVert* vertices = list->VtxBuffer.Data;
    const ImDrawIdx* indices = list->IdxBuffer.Data;
    for (const ImDrawCmd& cmd : list->CmdBuffer) {
      if (cmd.UserCallback) {
        if (cmd.UserCallback != ImDrawCallback_ResetRenderState) cmd.UserCallback(list, &cmd);
        continue;
      }
      const ImVec2 clip_min((cmd.ClipRect.x - pos.x) * scale.x, (cmd.ClipRect.y - pos.y) * scale.y);
      const ImVec2 clip_max((cmd.ClipRect.z - pos.x) * scale.x, (cmd.ClipRect.w - pos.y) * scale.y);
      if (clip_max.x <= clip_min.x || clip_max.y <= clip_min.y) continue;
      glScissor(static_cast<GLint>(clip_min.x), static_cast<GLint>(fb_h - clip_max.y),
                static_cast<GLsizei>(clip_max.x - clip_min.x),
                static_cast<GLsizei>(clip_max.y - clip_min.y));
      glBindTexture(GL_TEXTURE_2D,
                    static_cast<GLuint>(reinterpret_cast<std::intptr_t>(cmd.GetTexID())));
      const ImDrawVert* v = vertices + cmd.VtxOffset;
      glVertexPointer(2, GL_FLOAT, kStride, &v->pos);
      glTexCoordPointer(2, GL_FLOAT, kStride, &v->uv);
      glColorPointer(4, GL_UNSIGNED_BYTE, kStride, &v->col);
      glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(cmd.ElemCount), kIndexType,
                     indices + cmd.IdxOffset);
    }
  }

  glDisableClientState(GL_COLOR_ARRAY);
  glDisableClientState(GL_TEXTURE_COORD_ARRAY);
  glDisableClientState(GL_VERTEX_ARRAY);
  glDisable(GL_SCISSOR_TEST);
}

}  // namespace gb::ui
