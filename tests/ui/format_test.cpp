// The number formats of the estimate and parameters views, and the heat map's palette.
#include "ui/format.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "ui/widgets/heatmap.h"
#include "ui/widgets/plot_axis.h"

namespace gb::ui {
namespace {

int Channel(ImU32 c, int shift) { return static_cast<int>((c >> shift) & 0xFF); }

TEST(Format, NonFiniteAndAbsentValuesAreADashNotNan) {
  EXPECT_EQ(FormatSig(std::numeric_limits<double>::quiet_NaN(), 4), kDash);
  EXPECT_EQ(FormatSig(HUGE_VAL, 4), kDash);
  EXPECT_EQ(FormatSig(std::optional<double>{}, 4), kDash);
  EXPECT_EQ(FormatFixed(std::numeric_limits<double>::quiet_NaN(), 2), kDash);
  EXPECT_EQ(FormatPValue(std::nullopt), kDash);
}

TEST(Format, EveryNonFiniteValueIsADashInEveryFormat) {
  const double kInf = std::numeric_limits<double>::infinity();
  const double kNaN = std::numeric_limits<double>::quiet_NaN();
  for (double v : {kNaN, -kNaN, kInf, -kInf}) {
    EXPECT_EQ(FormatSig(v, 6), kDash);
    EXPECT_EQ(FormatSig(std::optional<double>(v), 3), kDash);
    EXPECT_EQ(FormatFixed(v, 3), kDash);
    EXPECT_EQ(FormatPValue(v), kDash);
    EXPECT_EQ(plot::FormatValue(v), std::isnan(v) ? "missing" : "not finite");
  }
  // The largest and smallest finite numbers are still numbers.
  EXPECT_EQ(FormatSig(std::numeric_limits<double>::max(), 3), "1.8e+308");
  EXPECT_EQ(FormatSig(std::numeric_limits<double>::denorm_min(), 2), "4.9e-324");
}

TEST(Format, SignificantDigitsWithoutExponentForWholeNumbers) {
  EXPECT_EQ(FormatSig(0.0739473, 5), "0.073947");
  EXPECT_EQ(FormatSig(1603.2, 3), "1603");
  EXPECT_EQ(FormatSig(1.2e-5, 3), "1.2e-05");
  EXPECT_EQ(FormatSig(70.8, 3), "70.8");
}

TEST(Format, PValuesBelowRoundingNoiseAreBounded) {
  EXPECT_EQ(FormatPValue(0.0), "<1e-16");
  EXPECT_EQ(FormatPValue(0.675), "0.675");
}

TEST(HeatMapPalette, DivergesFromWhiteToBlueAndRed) {
  const ImU32 lo = plot::DivergingColor(-1.0), mid = plot::DivergingColor(0.0),
              hi = plot::DivergingColor(1.0);
  // Blue at -1, red at +1, a light neutral at 0.
  EXPECT_GT(Channel(lo, IM_COL32_B_SHIFT), Channel(lo, IM_COL32_R_SHIFT));
  EXPECT_GT(Channel(hi, IM_COL32_R_SHIFT), Channel(hi, IM_COL32_B_SHIFT));
  for (int shift : {IM_COL32_R_SHIFT, IM_COL32_G_SHIFT, IM_COL32_B_SHIFT})
    EXPECT_GT(Channel(mid, shift), 240);
  // Values beyond the scale are clamped; NaN is neutral.
  EXPECT_EQ(plot::DivergingColor(5.0), hi);
  EXPECT_EQ(plot::DivergingColor(std::numeric_limits<double>::quiet_NaN()), mid);
  // Readable text on the ends and on the middle.
  EXPECT_EQ(plot::TextColorOn(hi), IM_COL32(255, 255, 255, 255));
  EXPECT_NE(plot::TextColorOn(mid), IM_COL32(255, 255, 255, 255));
}

}  // namespace
}  // namespace gb::ui
