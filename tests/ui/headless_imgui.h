// A headless ImGui context for widget tests (no window, no GL): created in SetUp with the given
// display size and the font atlas built, destroyed in TearDown. Tests derive their fixture from
// it and drive frames themselves.
#pragma once

#include <gtest/gtest.h>
#include <imgui.h>

namespace gb::ui::testing {

class HeadlessImGuiTest : public ::testing::Test {
 protected:
  HeadlessImGuiTest(float width, float height) : width_(width), height_(height) {}

  void SetUp() override {
    context_ = ImGui::CreateContext();
    ImGuiIO& io = ImGui::GetIO();
    io.IniFilename = nullptr;
    io.DisplaySize = ImVec2(width_, height_);
    io.DeltaTime = 1.0f / 60.0f;
    unsigned char* pixels = nullptr;
    int w = 0, h = 0;
    io.Fonts->GetTexDataAsRGBA32(&pixels, &w, &h);
  }
  void TearDown() override { ImGui::DestroyContext(context_); }

  ImGuiContext* context_ = nullptr;
  float width_, height_;
};

}  // namespace gb::ui::testing
